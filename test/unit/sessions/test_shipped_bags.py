"""The shipped sessions in bags/ carry what rosbag2 Jazzy writes.

ros_distro jazzy in metadata.yaml, a topic_type_hash on every MCAP channel, and each publisher's offered QoS
as discovery showed it (AUTOMATIC liveliness, durations infinite as RMW_DURATION_INFINITE: 9223372036 s
854775807 ns).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader

REPO = Path(__file__).resolve().parents[3]
BAGS = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').is_file())
INFINITE = {'sec': 9223372036, 'nsec': 854775807}


@pytest.mark.parametrize('bag', BAGS, ids=[p.name for p in BAGS])
def test_metadata_and_channels_are_as_rosbag2_jazzy_writes_them(bag: Path) -> None:
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['ros_distro'] == 'jazzy'
    assert info['storage_identifier'] == 'mcap'
    for entry in info['topics_with_message_count']:
        meta = entry['topic_metadata']
        assert meta['type_description_hash'].startswith('RIHS01_'), meta['name']
        profiles = meta['offered_qos_profiles']
        assert profiles, f'{meta["name"]}: no offered QoS recorded'
        for qos in profiles:
            assert qos['liveliness'] == 'automatic', meta['name']
            for key in ('deadline', 'lifespan', 'liveliness_lease_duration'):
                assert qos[key] == INFINITE, (meta['name'], key, qos[key])
    for path in info['relative_file_paths']:
        with open(bag / path, 'rb') as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None
        for channel in summary.channels.values():
            assert channel.metadata.get('topic_type_hash', '').startswith('RIHS01_'), channel.topic
