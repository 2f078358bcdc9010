"""``python -m grasp_intent_ros.report``: runs :mod:`grasp_intent_ros.tools.report`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.report', run_name='__main__', alter_sys=True)
