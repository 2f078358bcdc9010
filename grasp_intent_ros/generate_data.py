"""``python -m grasp_intent_ros.generate_data``: runs :mod:`grasp_intent_ros.dataset.generate_data`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.dataset.generate_data', run_name='__main__', alter_sys=True)
