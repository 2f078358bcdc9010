"""Multi-task grasp model: inclusive labeling, posterior, analytic gradient, persistence."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable

import numpy as np
import pytest
import yaml
from numpy.testing import assert_allclose

from grasp_intent_ros.errors import DataError, InvalidFeaturesError, ModelError, ModelFormatError
from grasp_intent_ros.method import model as model_module
from grasp_intent_ros.method.data import Demonstrations, load_csv, save_csv
from grasp_intent_ros.method.features import MICO_3F
from grasp_intent_ros.method.intent import DEFAULT_TASKS
from grasp_intent_ros.method.model import (
    MAX_FEATURE_DIM,
    ZONE_STRUCTURES,
    GraspModel,
    ModelRequirements,
    _precisions_and_log_norms,
    structure_zones,
)
from grasp_intent_ros.method.safe_yaml import (
    ALIAS,
    MAX_DOCUMENT_CHARS,
    MAX_DOCUMENT_DEPTH,
    NOT_YAML,
    TOO_DEEP,
    parse_document,
)
from grasp_intent_ros.resources import config_dir

from ..conftest import synthetic_demos


def test_inclusive_labeling_counts(demos: Demonstrations, toy_model: GraspModel) -> None:
    per_set = demos.counts()
    for k, zone in enumerate(toy_model.zones):
        expected = sum(n for s, n in per_set.items() if s & zone == zone)
        assert toy_model.counts[k] == expected
    # zone "U" (bit 0) trains on U, UT, UH and UTH demonstrations
    assert toy_model.counts[0] == 4 * 40
    assert_allclose(toy_model.priors, toy_model.counts / toy_model.counts.sum())
    # zone mean is the mean of its inclusive demonstrations
    rows = (demos.task_sets & 0b011) == 0b011
    assert_allclose(toy_model.means[toy_model.zones.index(0b011)], demos.x[rows].mean(axis=0), atol=1e-12)


def test_structure_drops_events_the_structure_rules_out(demos: Demonstrations) -> None:
    zones = structure_zones('5zone', DEFAULT_TASKS)
    assert zones == (0b001, 0b010, 0b011, 0b110, 0b111)
    m5 = GraspModel.fit(demos, zones)
    # H-only and UH demonstrations are left out, so task H = TH + UTH only
    assert m5.task_counts.tolist() == [3 * 40, 4 * 40, 2 * 40]
    assert len(m5.demo_x) == 5 * 40


def test_posterior_is_normalised_and_stable_far_away(toy_model: GraspModel) -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(MICO_3F.lower, MICO_3F.upper, (200, MICO_3F.dim))
    p = toy_model.posterior(x)
    assert p.shape == (200, 7)
    assert_allclose(p.sum(axis=1), 1.0, atol=1e-12)
    far = np.full(MICO_3F.dim, 1e3)
    p_far = toy_model.posterior(far)
    assert np.all(np.isfinite(p_far)) and p_far.sum() == pytest.approx(1.0)
    assert_allclose(toy_model.posterior(x[0]), p[0], atol=1e-15)


def test_x_too_far_for_a_finite_posterior_is_rejected_not_nan(toy_model: GraspModel) -> None:
    p = toy_model.posterior(np.full(MICO_3F.dim, 1e100))  # far, but the log-likelihoods are finite
    assert np.all(np.isfinite(p)) and p.sum() == pytest.approx(1.0)
    for x in (np.full(MICO_3F.dim, 1e308), np.r_[np.zeros(9), -1e200]):
        with pytest.raises(InvalidFeaturesError, match='too far from every zone'):
            toy_model.posterior(x)
        with pytest.raises(InvalidFeaturesError, match='too far from every zone'):
            toy_model.posterior_jacobian(np.stack([toy_model.means[0], x]))


def test_analytic_jacobian_matches_finite_differences(toy_model: GraspModel) -> None:
    """Relative error < 1e-5 at 100 random x near the data (central differences, h = 1e-6)."""
    rng = np.random.default_rng(2)
    idx = rng.integers(0, len(toy_model.demo_x), 100)
    xs = toy_model.demo_x[idx] + rng.normal(0.0, 0.02, (100, MICO_3F.dim))
    _, jac = toy_model.posterior_jacobian(xs)
    h = 1e-6
    for n, x in enumerate(xs):
        fd = np.empty((7, MICO_3F.dim))
        for i in range(MICO_3F.dim):
            e = np.zeros(MICO_3F.dim)
            e[i] = h
            fd[:, i] = (toy_model.posterior(x + e) - toy_model.posterior(x - e)) / (2 * h)
        scale = max(np.abs(fd).max(), 1e-3)
        assert np.abs(jac[n] - fd).max() / scale < 1e-5, n


def test_rank_deficient_zone_still_gives_a_valid_model() -> None:
    base = synthetic_demos(per_set=40)
    # the "UTH" zone gets 2 demonstrations only (rank 1 covariance before the ridge)
    keep = np.ones(len(base), dtype=bool)
    keep[np.flatnonzero(base.task_sets == 0b111)[2:]] = False
    m = GraspModel.fit(base.select(keep))
    assert m.counts[-1] == 2
    assert np.all(np.linalg.eigvalsh(m.covariances) > 0)
    assert np.all(np.isfinite(m.posterior(m.means)))


def test_zone_without_data_is_a_clear_error(demos: Demonstrations) -> None:
    only_u = demos.select(demos.task_sets == 0b001)
    with pytest.raises(ModelError, match='zone T has no demonstration'):
        GraspModel.fit(only_u)
    with pytest.raises(ModelError, match='ridge'):
        GraspModel.fit(demos, ridge=0.0)


def test_yaml_round_trip(tmp_path, toy_model: GraspModel) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / 'models' / 'toy.yaml'
    toy_model.save(path)
    loaded = GraspModel.load(path)
    assert loaded.zones == toy_model.zones and loaded.task_names == toy_model.task_names
    assert loaded.feature_names == MICO_3F.names and loaded.data_hash == toy_model.data_hash
    assert_allclose(loaded.means, toy_model.means, atol=1e-12)
    assert_allclose(loaded.covariances, toy_model.covariances, atol=1e-12)
    assert_allclose(loaded.demo_x, toy_model.demo_x, atol=1e-6)
    x = toy_model.demo_x[:10]
    assert_allclose(loaded.posterior(x), toy_model.posterior(x), atol=1e-6)
    text = path.read_text()
    for word in ('palm_x', 'unit', 'covariance', 'prior', 'count', 'data_hash', 'UTH'):
        assert word in text


@pytest.mark.parametrize(('mutate', 'match'), [
    (lambda d: d.pop('zone_models'), 'lacks field'),
    (lambda d: d.__setitem__('format_version', 99), 'format_version'),
    (lambda d: d['zone_models'][0].__setitem__('mean', [0.0]), r'zone_models\[0\].mean must have 10 values'),
    (lambda d: d['zone_models'][0].__setitem__('covariance', (-np.eye(10)).tolist()), 'positive definite'),
    (lambda d: d['zone_models'][1].__setitem__('prior', 5.0), 'priors'),
    (lambda d: d.__setitem__('zones', ['U', 'X']), 'unknown zone'),
])
def test_malformed_documents_raise(toy_model: GraspModel, mutate, match) -> None:  # type: ignore[no-untyped-def]
    doc = toy_model.to_document()
    mutate(doc)
    with pytest.raises(ModelFormatError, match=match):
        GraspModel.from_document(doc)


def test_a_body_needs_the_palm_centre_as_the_first_features() -> None:
    doc = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml').to_document()
    assert GraspModel.from_document(doc).body is not None
    doc['features'][0]['name'] = 'wrist_x'
    with pytest.raises(ModelFormatError, match=r"palm centre as its first three features .*'wrist_x'"):
        GraspModel.from_document(doc)
    del doc['body']
    assert GraspModel.from_document(doc).features.names[0] == 'wrist_x'


def test_bad_yaml_and_bad_x(toy_model: GraspModel) -> None:
    with pytest.raises(ModelFormatError):
        GraspModel.from_yaml('zones: [unclosed')
    with pytest.raises(ModelFormatError):
        GraspModel.from_yaml('- a list')
    with pytest.raises(InvalidFeaturesError):
        toy_model.posterior(np.zeros(3))
    with pytest.raises(InvalidFeaturesError):
        toy_model.posterior(np.full(10, np.nan))


def test_shipped_models_read_as_pyyaml_reads_them() -> None:
    for path in sorted((config_dir() / 'models').glob('*.yaml')):
        reference = GraspModel.from_document(yaml.safe_load(path.read_text()))
        assert GraspModel.load(path).to_yaml() == reference.to_yaml(), path.name


SCALARS = ('- 1\n- -2.5e-3\n- .inf\n- .nan\n- null\n- ~\n- true\n- No\n- 0x1F\n- 0o17\n- 1_000\n- 2001-12-14\n'
           '- !!binary aGVsbG8=\n- "quoted: x"\n- !!str 3\n- !!float 1\n- \'<<\'\n- plain text\n- ""\n- []\n- {}')


@pytest.mark.parametrize('text', [SCALARS, '', '# only a comment\n', '---\n...\n', 'a', '{a: 1, b: [1, {c: d}], 3: x, '
                                  'null: y, 1.5: z}', 'a: 1\na: 2', '!!map {a: 1}', '! x'])
def test_documents_read_as_pyyaml_safe_load_reads_them(text: str) -> None:
    assert repr(parse_document(text)) == repr(yaml.safe_load(text))  # repr: nan != nan


DECIMALS = ('1.5', '-0.0', '+2.', '0.25e-07', '1.5E+3', '-7.0e+999', '1.5e3', '1e-3', '.5', '-.5', '1_0.5', '0x1F',
            '1:30.5', '"1.5"', "'2.5'", '!!str 1.5', '! 1.5', '!!float 2.5', '1.5.5', '1.5 x', '12', '-1.5')


@pytest.mark.parametrize('scalar', DECIMALS)
def test_decimal_like_scalars_read_as_pyyaml_safe_load_reads_them(scalar: str) -> None:
    """The plain-decimal shortcut (``_PLAIN_DECIMAL``) and what it must leave to the resolver: the same values."""
    for text in (f'- {scalar}\n', f'[{scalar}]', f'a: {scalar}\n'):
        ours, theirs = parse_document(text), yaml.safe_load(text)
        assert repr(ours) == repr(theirs), text  # repr: the type, and -0.0 apart from 0.0
        assert [type(x) for x in (ours if isinstance(ours, list) else ours.values())] == \
            [type(x) for x in (theirs if isinstance(theirs, list) else theirs.values())], text


def test_shipped_model_documents_read_as_pyyaml_safe_load_reads_them() -> None:
    for path in sorted((config_dir() / 'models').glob('*.yaml')):
        text = path.read_text()
        assert parse_document(text) == yaml.safe_load(text), path.name


@pytest.mark.parametrize('text', [
    '<<: {a: 1}\nb: 2',  # merge keys: safe_load merges them
    'a: !!set {x, y}',
    'a: !!omap [{x: 1}]',
    'a: !!python/object:os.system x',
    '? [1, 2]\n: x',  # an unhashable key
    '--- 1\n--- 2',  # several documents
    'a: [1',
])
def test_documents_beyond_plain_data_are_rejected(text: str) -> None:
    with pytest.raises(ModelFormatError) as err:
        parse_document(text)
    assert err.value.reason == NOT_YAML


def test_nesting_is_bounded() -> None:
    assert parse_document('[' * MAX_DOCUMENT_DEPTH + ']' * MAX_DOCUMENT_DEPTH) is not None
    for deep in ('[' * (MAX_DOCUMENT_DEPTH + 1) + ']' * (MAX_DOCUMENT_DEPTH + 1),
                 'a:\n' + ''.join('  ' * i + 'b:\n' for i in range(1, MAX_DOCUMENT_DEPTH + 1)) + '  ' * 33 + '- 1\n'):
        with pytest.raises(ModelFormatError) as err:
            parse_document(deep)
        assert err.value.reason == TOO_DEEP and f'more than {MAX_DOCUMENT_DEPTH} levels' in str(err.value)


def test_reading_a_document_holds_little_more_than_the_document() -> None:
    """No node tree: the peak is the document's own lists and dicts.

    PyYAML's composer held about 4 MB of Python objects for a 7-zone model, which a node's first reading
    of a model left behind as pymalloc arenas (RSS steps in the soak).
    """
    text = (config_dir() / 'models' / 'cup_7zone.yaml').read_text()
    tracemalloc.start()
    try:
        doc = parse_document(text)
        kept, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert doc['zones'] == list(ZONE_STRUCTURES['7zone'])
    assert peak < 1.5 * kept and peak < (1 << 20), (kept, peak)


def test_documents_are_written_as_pyyaml_writes_them(toy_model: GraspModel) -> None:
    """The libyaml emitter gives PyYAML's text, so a document (and its hash) does not depend on the writer."""
    for model in (toy_model, GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')):  # the latter: a body
        text = model.to_yaml()
        body = yaml.safe_dump(model.to_document(), sort_keys=False, width=120)
        assert text.endswith(body) and text.count('\n') == body.count('\n') + 2, model.name


def _traced_peak(call: Callable[[], object]) -> int:
    tracemalloc.start()
    try:
        call()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_writing_a_document_holds_little_more_than_the_document() -> None:
    """No node tree: yaml.dump represented a 7-zone model as 3 MB of Python objects before writing it."""
    model = GraspModel.load(config_dir() / 'models' / 'cup_7zone.yaml')
    document = _traced_peak(model.to_document)  # the plain lists and dicts the text is written from
    assert _traced_peak(model.to_yaml) < 2 * document, document


def test_aliases_are_rejected_before_anything_expands(toy_model: GraspModel) -> None:
    text = toy_model.to_yaml()
    names = '\n'.join(f'- {t}' for t in toy_model.task_names)
    assert f'task_names:\n{names}\n' in text
    one_alias = text.replace(f'task_names:\n{names}\n', 'task_names: *tasks\n').replace(
        'format_version: 1\n', f'format_version: 1\ntasks: &tasks\n{names}\n')
    with pytest.raises(ModelFormatError) as err:
        GraspModel.from_yaml(one_alias)
    assert err.value.reason == ALIAS
    # "billion laughs": 10^9 items once expanded, 1 kB of text
    laughs = ['a0: &a0 [x, x, x, x, x, x, x, x, x, x]']
    laughs += [f'a{i}: &a{i} [{", ".join([f"*a{i - 1}"] * 10)}]' for i in range(1, 10)]
    with pytest.raises(ModelFormatError) as err:
        GraspModel.from_yaml('\n'.join(laughs))
    assert err.value.reason == ALIAS


@pytest.mark.parametrize('text', ['[' * 100_000, '- ' * 100_000, '{a: ' * 100_000, '[' * 40 + '"' + ']' * 5])
def test_nesting_too_deep_is_rejected_without_crashing(text: str) -> None:
    """The C composer of libyaml would recurse without a limit here and crash the process.

    The reason is the same whichever layer stops the document: this reader's depth limit, or libyaml's own
    (its scanner stops flow nesting at a depth of its version's choosing, before this reader sees the events).
    """
    with pytest.raises(ModelFormatError) as err:
        GraspModel.from_yaml(text)
    assert err.value.reason == TOO_DEEP


def test_oversized_documents_are_rejected_before_parsing(tmp_path, toy_model: GraspModel) -> None:  # type: ignore[no-untyped-def]
    text = toy_model.to_yaml()
    padded = text + '#' * (MAX_DOCUMENT_CHARS - len(text) - 1) + '\n'  # a valid model of the largest size
    assert len(padded) == MAX_DOCUMENT_CHARS
    assert GraspModel.from_yaml(padded).to_yaml() == text
    with pytest.raises(ModelFormatError, match=f'oversized: more than {MAX_DOCUMENT_CHARS} characters'):
        GraspModel.from_yaml(padded + '\n')
    path = tmp_path / 'big.yaml'
    path.write_text(padded + '#' * MAX_DOCUMENT_CHARS)
    with pytest.raises(ModelFormatError, match='oversized'):
        GraspModel.load(path)
    with pytest.raises(ModelFormatError, match='malformed value'):
        GraspModel.from_yaml('format_version: ' + '9' * 5000)


def test_csv_round_trip_and_errors(tmp_path, demos: Demonstrations) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / 'd.csv'
    save_csv(demos, path)
    back = load_csv(path)
    assert back.task_names == DEFAULT_TASKS
    assert_allclose(back.x, demos.x, atol=1e-6)
    assert (back.task_sets == demos.task_sets).all()
    assert back.sha256() == load_csv(path).sha256()
    lines = path.read_text().splitlines()
    bad = tmp_path / 'bad.csv'
    bad.write_text('\n'.join([lines[0], lines[1].rsplit(',', 1)[0] + ',2']))
    with pytest.raises(DataError, match=r'bad.csv:2: task column'):
        load_csv(bad)
    bad.write_text('\n'.join([lines[0], ','.join(['0'] * 13)]))
    with pytest.raises(DataError, match='satisfies no task'):
        load_csv(bad)
    bad.write_text('a,b,c\n1,2,3\n')
    with pytest.raises(DataError, match='first 10 columns'):
        load_csv(bad)


def test_precisions_and_normalisers_are_those_of_the_covariances() -> None:
    rng = np.random.default_rng(0)
    a = rng.standard_normal((3, 10, 10))
    covs = a @ np.swapaxes(a, 1, 2) + 0.1 * np.eye(10)
    priors = np.array([0.2, 0.3, 0.5])
    prec, log_norm = _precisions_and_log_norms(covs, priors)
    assert np.array_equal(prec, np.swapaxes(prec, 1, 2))  # exactly symmetric
    # the references run numpy's BLAS/LAPACK, whose kernels sum in orders of the CPU's own; in any order, a
    # factorisation of a d x d matrix gives products and log determinants within about d * eps * cond(c) of
    # the exact ones: the bound is 10 times that (6e-12 here, cond(c) <= 284)
    bound = 10 * 10 * np.finfo(float).eps * max(np.linalg.cond(c) for c in covs)
    assert_allclose(prec @ covs, np.broadcast_to(np.eye(10), covs.shape), atol=bound)
    expected = [np.log(p) - 0.5 * np.linalg.slogdet(2.0 * np.pi * c)[1] for p, c in zip(priors, covs)]
    assert_allclose(log_norm, expected, rtol=0.0, atol=bound)


@pytest.mark.parametrize('cov', [-np.eye(4), np.diag([1.0, 1.0, 0.0, 1.0]), np.full((4, 4), np.nan),
                                 np.array([[1.0, 2.0], [2.0, 1.0]])])
def test_a_covariance_that_is_not_positive_definite_is_refused(cov: np.ndarray) -> None:
    with pytest.raises(ModelFormatError, match='positive definite'):
        _precisions_and_log_norms(cov[None], np.ones(1))


def test_a_covariance_whose_inverse_overflows_is_refused() -> None:
    with pytest.raises(ModelFormatError, match='too close to singular'):
        _precisions_and_log_norms(np.diag([1.0, 1e-310, 1.0])[None], np.ones(1))


# ---------------------------------------------------------------------------------------------- cheap checks first
SERVED = ModelRequirements(task_names=DEFAULT_TASKS, feature_names=MICO_3F.names)
UNPARSABLE_TAIL = 'zzz: [unclosed\n'
"""Invalid YAML after a document's arrays: a reader that reports it, rather than the declaration, read them all."""


def _text(doc: dict) -> str:  # type: ignore[type-arg]
    return yaml.safe_dump(doc, sort_keys=False)


@pytest.fixture
def no_model_built(monkeypatch: pytest.MonkeyPatch) -> None:
    """Building a model (the covariances' Cholesky, the expensive step) fails the test."""
    def built(*_: object) -> None:
        raise AssertionError('the model was built')
    monkeypatch.setattr(model_module, '_precisions_and_log_norms', built)


@pytest.mark.parametrize(('mutate', 'error', 'reason'), [
    (lambda d: d.__setitem__('task_names', [f'task{i}' for i in range(10)]), ModelError,
     r'its tasks \[task0, task1, .*\] are not the task_names \[usage, transfer, handover\]'),
    (lambda d: d['features'][0].__setitem__('name', 'wrist_x'), ModelError, "its features .* are not the robot's"),
    (lambda d: d.__setitem__('features', [dict(f) for f in d['features'] * 48]), ModelFormatError,
     f'features must list 1 to {MAX_FEATURE_DIM} features, got 480'),
    (lambda d: d.__setitem__('task_names', [f't{i}' for i in range(11)]), ModelFormatError,
     'task_names must list 1 to 10 tasks, got 11'),
    (lambda d: d.__setitem__('zones', d['zones'] + ['U']), ModelFormatError, 'zones must list 1 to 7 zones'),
    (lambda d: d.__setitem__('format_version', 2), ModelFormatError, 'unsupported model format_version'),
])
def test_a_document_is_refused_by_its_declaration_before_its_arrays_are_parsed(
        toy_model: GraspModel, no_model_built: None, mutate, error, reason) -> None:  # type: ignore[no-untyped-def]
    """A document is refused by what it declares, before its arrays are parsed and before any model is built.

    Timing-free: the arrays are followed by invalid YAML, so a refusal that names the declaration was made
    before the parser got there; and building a model fails the test (``no_model_built``).
    """
    doc = toy_model.to_document()
    mutate(doc)
    with pytest.raises(error, match=reason):
        GraspModel.from_yaml(_text(doc) + UNPARSABLE_TAIL, requires=SERVED)


def test_the_declaration_must_come_before_the_arrays(toy_model: GraspModel, no_model_built: None) -> None:
    doc = toy_model.to_document()
    arrays_first = {'zone_models': doc.pop('zone_models'), **doc}
    with pytest.raises(ModelFormatError, match="lists 'zone_models' before declaring format_version, task_names"):
        GraspModel.from_yaml(_text(arrays_first) + UNPARSABLE_TAIL)


def test_a_document_whose_keys_a_dumper_sorted_is_refused_with_the_fix(toy_model: GraspModel) -> None:
    """yaml.safe_dump sorts keys by default ('demonstrations' first): the error says how to write it instead."""
    doc = yaml.safe_load(toy_model.to_yaml())
    with pytest.raises(ModelFormatError, match=r"lists 'demonstrations' before declaring .*GraspModel\.save.*"
                                               r"sort_keys=False"):
        GraspModel.from_yaml(yaml.safe_dump(doc))
    assert GraspModel.from_yaml(yaml.safe_dump(doc, sort_keys=False)).name == toy_model.name


@pytest.mark.parametrize(('mutate', 'reason'), [
    (lambda d: d['demonstrations'][-1].__setitem__('x', [0.0] * 11),
     r'demonstrations\[\d+\].x must have 10 values \(one per feature\), got 11'),
    (lambda d: d['task_models'][2]['covariance'][9].append(0.0), r'task_models\[2\].covariance\[9\] must have 10'),
    (lambda d: d['zone_models'].pop(), 'zone_models must list 7 entries'),
    (lambda d: d.__setitem__('demonstrations', []), 'demonstrations must list at least one'),
])
def test_arrays_of_the_wrong_size_are_refused_before_the_model_is_built(
        toy_model: GraspModel, no_model_built: None, mutate, reason) -> None:  # type: ignore[no-untyped-def]
    doc = toy_model.to_document()
    mutate(doc)
    with pytest.raises(ModelFormatError, match=reason):
        GraspModel.from_yaml(_text(doc), requires=SERVED)


def test_a_served_model_reads_as_without_requirements(toy_model: GraspModel) -> None:
    text = toy_model.to_yaml()
    assert GraspModel.from_yaml(text, requires=SERVED).to_yaml() == text
    assert GraspModel.from_yaml(text, requires=ModelRequirements()).to_yaml() == text
