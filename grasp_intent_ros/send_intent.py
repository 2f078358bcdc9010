"""``python -m grasp_intent_ros.send_intent``: runs :mod:`grasp_intent_ros.tools.send_intent`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.send_intent', run_name='__main__', alter_sys=True)
