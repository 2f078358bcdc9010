"""``python -m grasp_intent_ros.recorder``: runs :mod:`grasp_intent_ros.tools.recorder`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.recorder', run_name='__main__', alter_sys=True)
