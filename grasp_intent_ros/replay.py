"""``python -m grasp_intent_ros.replay``: runs :mod:`grasp_intent_ros.tools.replay`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.replay', run_name='__main__', alter_sys=True)
