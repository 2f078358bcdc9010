"""``python -m grasp_intent_ros.train``: runs :mod:`grasp_intent_ros.dataset.train`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.dataset.train', run_name='__main__', alter_sys=True)
