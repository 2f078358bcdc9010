"""``python -m grasp_intent_ros.reindex``: runs :mod:`grasp_intent_ros.tools.reindex`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.reindex', run_name='__main__', alter_sys=True)
