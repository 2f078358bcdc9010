"""``python -m grasp_intent_ros.playback``: runs :mod:`grasp_intent_ros.tools.playback`."""

import runpy

if __name__ == '__main__':
    runpy.run_module('grasp_intent_ros.tools.playback', run_name='__main__', alter_sys=True)
