"""``python -m grasp_intent_ros.paper_tables``: runs :mod:`grasp_intent_ros.tools.paper_tables`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.paper_tables', run_name='__main__', alter_sys=True)
