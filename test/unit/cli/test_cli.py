"""The library-only command-line tools: paper tables and the ambiguity report (no ROS)."""

from __future__ import annotations

import pytest

from grasp_intent_ros.cli import ambiguity_report, paper_tables


def test_paper_tables_prints_every_case(capsys: pytest.CaptureFixture[str]) -> None:
    assert paper_tables.main([]) == 0
    out = capsys.readouterr().out
    for title, _, names in paper_tables.CASES:
        assert title in out
        for name in names:
            assert f'model {name}' in out
    assert out.count('objective') == sum(len(names) for _, _, names in paper_tables.CASES)
    assert 'needs clarification' not in out


def test_paper_tables_reports_a_missing_models_dir(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:  # type: ignore[no-untyped-def]
    assert paper_tables.main(['--models-dir', str(tmp_path)]) == 2
    assert 'not found' in capsys.readouterr().err


def test_ambiguity_report_side_by_side(capsys: pytest.CaptureFixture[str]) -> None:
    assert ambiguity_report.main([]) == 0
    out = capsys.readouterr().out
    for name in ambiguity_report.DEFAULT_MODELS:
        assert name in out
    assert out.count('KL(row || column)') == 3 and out.count('Pinsker bound') == 3


def test_ambiguity_report_bad_file(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:  # type: ignore[no-untyped-def]
    bad = tmp_path / 'bad.yaml'
    bad.write_text('zones: [')
    assert ambiguity_report.main([str(bad)]) == 2
    assert 'error:' in capsys.readouterr().err
