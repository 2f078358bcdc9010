"""``python -m grasp_intent_ros.demo``: runs :mod:`grasp_intent_ros.tools.demo`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.demo', run_name='__main__', alter_sys=True)
