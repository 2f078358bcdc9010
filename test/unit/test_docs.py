"""The docs match the code: the layer table, each folder's module list, public names, docstrings' content.

- CONTRIBUTING.md's layer table names every module of the package under its folder;
- every package's docstring names each of its modules (its one job and what is in it);
- every name in a module's ``__all__`` is defined there;
- docstrings state contracts and reasons, never dates or measured figures (those go to
  docs/measurements.md and the README's table, history to git);
- every dotted name ``grasp_intent_ros.x.y`` and every ``python -m grasp_intent_ros <command>`` written in the
  package, its docs, config, benchmarks and tests names a module (and a name defined in it) or a command that
  exists, so a move leaves no stale pointer behind; so does every quoted repository path (``test/...``,
  ``ros/worker.LatestOnlyWorker``, ``path.py::test_name``), every test or benchmark path, quoted or not, and
  every link of the Markdown docs, to a file and a heading; and every dotted name the docs quote from a folder,
  module or class of the package (``shared_control.joint_path.line_turns``, ``HandCollision.open_hand_depth``);
- every ``ros2 topic pub/echo`` of the docs names a topic of :mod:`grasp_intent_ros.wire.topics` with its type,
  every ``ros2 param set/get/describe`` a parameter of that node, and every domain id they write is none of the
  tests' (:data:`grasp_intent_ros.launch.suite.TEST_DOMAIN_IDS`);
- every type the docs give a topic is its type (:data:`grasp_intent_ros.wire.topics.MSGTYPES`), every topic a node
  names is in a topic table of the docs, and docs/viewer.md's table is the viewer's topics; every type the docs
  give a service is the one a node serves or calls it with;
- every value the docs state for a constant (``5 mm (`SWEEP_STEP`)``), a node's parameter (```standoff` = 8 cm``)
  or a topic's size cap (``16 kB on `intent/w```) is the code's, and each config/<node>.yaml sets its node's
  defaults but the changes the docs state;
- every ``--option`` written after a command (``python -m grasp_intent_ros <command>``, a benchmark script, a
  script of scripts/) is one its parser defines (a shell script: one its text names);
- docs/sessions.md names every file ``report`` writes;
- the README's library example runs.

Read from the source (ast) where they can; the checks of topics, parameters, commands and the README's example
import the ROS-free modules that hold them (wire.topics, the parameter tables, launch.suite, scene.state).
"""

from __future__ import annotations

import ast
import functools
import math
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from node_parameters import node_parameters, table_name

from grasp_intent_ros.launch.suite import OPTIONAL_NODES, SUITE_NODES

REPO = Path(__file__).resolve().parents[2]
PACKAGE = REPO / 'grasp_intent_ros'
MODULES = sorted(p for p in PACKAGE.rglob('*.py') if '__pycache__' not in p.parts)
DATE = re.compile(r'\b20\d\d-\d\d-\d\d\b|\b(?:January|February|March|April|May|June|July|August|September|October|'
                  r'November|December) 20\d\d\b')
FIGURE = re.compile(r'\(\w[\w ]*, measured\)|benchmark\'s #\d|\babout \d[\d.]* ?(?:MB|kB|GB|ms|us|µs)\b|'
                    r'\bpeak \d[\d.]* ?(?:MB|kB|GB)\b|\d[\d.]* ?(?:us|µs|ms) each\b|\bon a \d-core\b')
"""Measured figures as docstrings have carried them: '(... measured)', 'about 4 MB', '0.4 us each'."""


REFERENCE = re.compile(r'grasp_intent_ros(?:\.[A-Za-z_]\w*)+')
COMMAND = re.compile(r'(?:python -m grasp_intent_ros|ros2 run grasp_intent_ros|grasp-intent-ros) ([a-z_]+)')
TEXTS = sorted([*MODULES, *REPO.glob('*.md'), *(REPO / 'docs').glob('*.md'), *(REPO / 'config').glob('*.yaml'),
                *(p for d in ('benchmarks', 'scripts', 'test') for p in (REPO / d).rglob('*.py')
                  if '__pycache__' not in p.parts and p.name != 'test_docs.py')])
"""Every text a reader follows to the code (this file names stale ones on purpose)."""


def layer_table() -> dict[str, str]:
    """Folder (or top-level module) -> its text in CONTRIBUTING.md's layer table."""
    text = (REPO / 'CONTRIBUTING.md').read_text()
    block = text[text.index('## Layers'):]
    block = block[block.index('```') + 3:]
    block = block[:block.index('```')]
    rows: dict[str, str] = {}
    key = ''
    for line in block.splitlines():
        entry = re.match(r'^  (\S[^ ]*(?:, \S+)*)\s{2,}(.*)$', line)
        if entry:
            key = entry.group(1)
            rows[key] = entry.group(2)
        elif line.startswith('   ') and key:
            rows[key] += ' ' + line.strip()
        else:
            key = ''
    return rows


def docstrings(tree: ast.Module) -> Iterator[str]:
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield doc
        elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            yield node.value.value  # attribute docstrings


def test_the_layer_table_names_every_module_under_its_folder() -> None:
    rows = layer_table()
    missing = []
    for path in MODULES:
        parts = path.relative_to(PACKAGE).with_suffix('').parts
        if len(parts) == 1:
            if parts[0] != '__init__' and not any(re.search(rf'(?<![\w.]){re.escape(parts[0])}\b', k) for k in rows):
                missing.append(parts[0])
            continue
        folder = f'{parts[0]}/'
        name = parts[-1] if len(parts) == 2 else parts[-2] if parts[-1] == '__init__' else parts[-1]
        if name in ('__init__', '__main__'):
            continue
        if folder not in rows or not re.search(rf'\b{re.escape(name)}\b', rows[folder]):
            missing.append('/'.join(parts))
    assert missing == [], f"CONTRIBUTING.md's layer table does not name: {missing}"


@pytest.mark.parametrize('init', sorted(PACKAGE.rglob('__init__.py')), ids=lambda p: str(p.parent.name))
def test_every_package_docstring_names_its_modules(init: Path) -> None:
    doc = ast.get_docstring(ast.parse(init.read_text())) or ''
    subs = sorted({p.stem for p in init.parent.glob('*.py') if not p.stem.startswith('_')}
                  | {p.parent.name for p in init.parent.glob('*/__init__.py')})
    if init.parent == PACKAGE:
        return  # the package's own docstring points at the folders; CONTRIBUTING's table is the list
    assert [s for s in subs if not re.search(rf'\b{re.escape(s)}\b', doc)] == []


@pytest.mark.parametrize('path', MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_all_names_only_what_the_module_defines(path: Path) -> None:
    tree = ast.parse(path.read_text())
    defined: set[str] = set()
    exported: list[str] = []
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defined.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                for name in ast.walk(target):
                    if isinstance(name, ast.Name):
                        defined.add(name.id)
                        if name.id == '__all__' and isinstance(node.value, (ast.List, ast.Tuple)):
                            exported = [ast.literal_eval(e) for e in node.value.elts]
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            defined.update((a.asname or a.name).split('.')[0] for a in node.names)
        elif isinstance(node, ast.If):  # TYPE_CHECKING imports and the like
            for sub in ast.walk(node):
                if isinstance(sub, (ast.Import, ast.ImportFrom)):
                    defined.update((a.asname or a.name).split('.')[0] for a in sub.names)
    if path.name == '__init__.py':  # a package's __all__ may name its modules
        defined.update(p.stem for p in path.parent.glob('*.py'))
    assert [n for n in exported if n not in defined] == []


@pytest.mark.parametrize('path', MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_docstrings_carry_no_dates_or_measured_figures(path: Path) -> None:
    found = [m.group(0) for doc in docstrings(ast.parse(path.read_text()))
             for m in [*DATE.finditer(doc), *FIGURE.finditer(doc)]]
    assert found == [], f'{path.name}: move figures to docs/measurements.md, history to git: {found}'


def test_the_figure_and_date_patterns_catch_what_they_are_for() -> None:
    assert DATE.search('run on 2026-11-27') and DATE.search('as of November 2026')
    for text in ('a plan makes 30: 0.4 us each', 'about 4 MB for a document', '(flashlight, measured)',
                 "the benchmark's #192", 'peak 0.6 MB', 'on a 2-core machine'):
        assert FIGURE.search(text), text
    for text in ('polls every 50 ms', 'a rejected 500 kB message', '(measured against the grasp)'):
        assert not FIGURE.search(text), text


def defined_names(body: list[ast.stmt]) -> dict[str, list[ast.stmt]]:
    """Name -> the body of the class it names ([] for anything else) for a module's or class's statements."""
    names: dict[str, list[ast.stmt]] = {}
    for node in body:
        if isinstance(node, ast.ClassDef):
            names[node.name] = node.body
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names[node.name] = []
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                names.update((n.id, []) for n in ast.walk(target) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update(((a.asname or a.name).split('.')[0], []) for a in node.names)
    return names


def resolves(reference: str) -> bool:
    """Whether ``reference`` names a module of the package, then at most a name in it and a name in that class."""
    parts = reference.split('.')[1:]
    for k in range(len(parts), -1, -1):
        folder = PACKAGE.joinpath(*parts[:k])
        source = folder / '__init__.py' if folder.is_dir() else folder.with_suffix('.py')
        if source.is_file():
            break
    else:
        return False
    body = ast.parse(source.read_text()).body
    for name in parts[k:k + 2]:
        names = defined_names(body)
        if name not in names:
            return False
        body = names[name]
    return True


def test_every_reference_to_the_package_names_what_exists() -> None:
    from grasp_intent_ros.commands import COMMANDS
    stale = sorted({f'{path.relative_to(REPO)}: {m.group(0)}' for path in TEXTS for text in [path.read_text()]
                    for m in [*REFERENCE.finditer(text), *COMMAND.finditer(text)]
                    if (m.re is REFERENCE and not resolves(m.group(0)))
                    or (m.re is COMMAND and m.group(1) not in COMMANDS)})
    assert stale == [], f'references to what does not exist (moved or renamed?): {stale}'


def test_the_reference_check_tells_stale_names_from_live_ones() -> None:
    assert resolves('grasp_intent_ros.mico.mock_arm.MockArm.step') and resolves('grasp_intent_ros.commands')
    for stale in ('grasp_intent_ros.core.arm', 'grasp_intent_ros.mico.mock_arm.NoSuchArm',
                  'grasp_intent_ros.mico.mock_arm.MockArm.no_such_method'):
        assert not resolves(stale), stale


MARKDOWN = sorted([*REPO.glob('*.md'), *(REPO / 'docs').glob('*.md')])
CURRENT_DOCS = [path for path in MARKDOWN if not path.name.endswith('_history.md')]
"""The docs that state the code as it is (a ``*_history.md`` page keeps what was measured or decided, as written)."""
TOP_DIRS = ('grasp_intent_ros', 'test', 'benchmarks', 'scripts', 'config', 'bags', 'examples', 'docs', 'requirements',
            'resource')
FOLDERS = tuple(sorted(p.parent.name for p in PACKAGE.glob('*/__init__.py')))
PATH = re.compile(rf'`((?:{"|".join(TOP_DIRS + FOLDERS)})/[\w./-]*?)(?:::(\w+))?`')
"""A quoted path from the repository's root or the package's (``ros/worker.py``, ``ros/worker.LatestOnlyWorker``)."""
TEST_PATH = re.compile(r'(?<![\w/.`-])((?:test|benchmarks)/[\w/.-]*\.py)(?:::(\w+))?')
"""A test or benchmark named unquoted, as docstrings do (no reader writes files there, unlike config/)."""
LINK = re.compile(r'\]\(([^)\s]+)\)')
TOPIC_COMMAND = re.compile(r'ros2 topic (?:pub|echo)(?: --?[a-z][\w-]*(?: \d[\d.]*)?)* (/?[\w/]+)(?: (\w+/msg/\w+))?')
"""``ros2 topic pub/echo``, its options (a number after one is its value: no topic name starts with a digit), the
topic and the type."""
PARAM_COMMAND = re.compile(r'ros2 param (?:set|get|describe)(?: --[a-z][\w-]*)* (/[\w/]+) (\w+)')
DOMAIN = re.compile(r'(?:ROS_DOMAIN_ID=|--domain-id )(\d+)')


def stale_path(path: str, name: str | None) -> bool:
    """Whether a quoted repository ``path`` (then a test ``name`` defined in it) names nothing that exists."""
    path = path.rstrip('/.')
    if path.split('/')[0] in TOP_DIRS:
        target = REPO / path
    elif '.' in path.rsplit('/', 1)[-1] and not path.endswith('.py'):  # ros/worker.LatestOnlyWorker
        return not resolves('grasp_intent_ros.' + path.replace('/', '.'))
    else:
        target = PACKAGE / path
    if not target.exists():
        return True
    return name is not None and not re.search(rf'^\s*(?:async )?def {name}\b', target.read_text(), re.MULTILINE)


def test_every_quoted_repository_path_names_what_exists() -> None:
    stale = sorted({f'{path.relative_to(REPO)}: {m.group(0)}' for path in TEXTS for text in [path.read_text()]
                    for m in [*PATH.finditer(text), *TEST_PATH.finditer(text)] if stale_path(m.group(1), m.group(2))})
    assert stale == [], f'paths to what does not exist (moved or renamed?): {stale}'


def test_the_path_check_tells_stale_paths_from_live_ones() -> None:
    for live in ('test/unit/test_docs.py', 'ros/worker.py', 'ros/worker.LatestOnlyWorker', 'bags/flashlight/',
                 'test/unit/test_docs.py::test_the_path_check_tells_stale_paths_from_live_ones'):
        assert not stale_path(*(live.split('::') + [None])[:2]), live
    for stale in ('test/unit/test_assistance.py', 'ros/no_such_module.py', 'ros/worker.NoSuchWorker',
                  'test/unit/test_docs.py::test_no_such_test'):
        assert stale_path(*(stale.split('::') + [None])[:2]), stale


DOTTED = re.compile(r'`~?([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?:\(\))?`')
"""A quoted dotted name: ``shared_control.joint_path.line_turns``, ``collision.LIMITS``, ``HandCollision.step``."""
FILE_SUFFIXES = frozenset({'py', 'md', 'png', 'yaml', 'csv', 'urdf', 'xml', 'txt', 'json', 'jsonl', 'gz', 'mcap', 'sh',
                           'html', 'toml', 'cfg'})


@functools.cache
def short_names() -> dict[str, list[str]]:
    """A module's or a class's name -> the dotted paths under the package where one of that name lives."""
    names: dict[str, list[str]] = {}
    for path in MODULES:
        parts = path.relative_to(PACKAGE).with_suffix('').parts
        module = '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)
        if module:
            names.setdefault(module.rsplit('.', 1)[-1], []).append(module)
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.ClassDef):
                names.setdefault(node.name, []).append(f'{module}.{node.name}'.lstrip('.'))
    return names


def stale_dotted_name(name: str) -> bool:
    """Whether a quoted dotted name that starts with a folder, a module or a class of the package names nothing.

    ``shared_control.joint_path.line_turns`` is read from the package's root; ``joint_path.line_turns`` and
    ``HandCollision.open_hand_depth`` from each module or class of that name. Another name (``np.lexsort``, a
    file name) is not the package's: never stale.
    """
    head, _, rest = name.partition('.')
    if name.rsplit('.', 1)[1] in FILE_SUFFIXES:
        return False
    starts = [head] if head in FOLDERS else short_names().get(head, [])
    return bool(starts) and not any(resolves(f'grasp_intent_ros.{start}.{rest}') for start in starts)


def test_every_dotted_name_the_docs_quote_names_what_exists() -> None:
    found = [(path, m.group(1)) for path in CURRENT_DOCS for m in DOTTED.finditer(path.read_text())]
    assert len(found) >= 50
    stale = sorted({f'{path.relative_to(REPO)}: {name}' for path, name in found if stale_dotted_name(name)})
    assert stale == [], f'quoted names of the package that do not exist (moved or renamed?): {stale}'


def test_the_dotted_name_check_tells_stale_names_from_live_ones() -> None:
    for live in ('shared_control.joint_path.line_turns', 'joint_path.near_grasp', 'collision.LIMITS',
                 'HandCollision.open_hand_depth', 'mico.grasp.plan_grasp', 'np.lexsort', 'config/mock_arm.yaml',
                 'arbitration.py'):
        assert not stale_dotted_name(live), live
    for stale in ('shared_control.joint_path.line_turn', 'joint_path.no_such_function', 'HandCollision.no_method',
                  'mico.no_such_module.plan_grasp'):
        assert stale_dotted_name(stale), stale


def heading_anchors(path: Path) -> set[str]:
    """The anchors of ``path``'s headings, as GitHub makes them.

    Lower case, every character but letters, digits, '_', '-' and spaces dropped, spaces to '-', a repeated
    anchor suffixed -1, -2, ...; a line in a code block is no heading.
    """
    anchors: set[str] = set()
    seen: dict[str, int] = {}
    fenced = False
    for line in path.read_text().splitlines():
        fenced ^= line.startswith('```')
        heading = re.match(r'#{1,6} (.*)', line)
        if heading and not fenced:
            anchor = re.sub(r'[^\w\- ]', '', heading.group(1).strip().lower()).replace(' ', '-')
            anchors.add(f'{anchor}-{seen[anchor]}' if anchor in seen else anchor)
            seen[anchor] = seen.get(anchor, 0) + 1
    return anchors


def stale_link(source: Path, link: str) -> bool:
    """Whether a Markdown ``link`` in ``source`` (a web address is not checked) misses its file or heading."""
    if re.match(r'[a-z]+:', link):
        return False
    path, _, anchor = link.partition('#')
    target = source.parent / path if path else source
    return not target.exists() or bool(anchor) and target.suffix == '.md' and anchor not in heading_anchors(target)


def test_every_link_of_the_docs_names_a_file_and_heading_that_exist() -> None:
    stale = sorted(f'{path.relative_to(REPO)}: {m.group(1)}' for path in MARKDOWN
                   for m in LINK.finditer(path.read_text()) if stale_link(path, m.group(1)))
    assert stale == [], f'links to what does not exist (a heading renamed?): {stale}'


def test_the_link_check_tells_stale_links_from_live_ones() -> None:
    readme = REPO / 'README.md'
    for live in ('docs/nodes.md#the-dds-profile-and-a-clients-shell', 'LICENSE', '#quick-start', 'https://x.org/#y'):
        assert not stale_link(readme, live), live
    for stale in ('docs/nodes.md#no-such-heading', 'docs/no_such_page.md', '#quick-start-1'):
        assert stale_link(readme, stale), stale


def stale_ros2_command(match: re.Match[str]) -> bool:
    """Whether a ``ros2 topic`` or ``ros2 param`` command names a topic, type, node or parameter the suite lacks."""
    from node_parameters import node_parameters

    from grasp_intent_ros.commands import COMMANDS
    from grasp_intent_ros.wire.topics import MSGTYPES
    if match.re is TOPIC_COMMAND:
        name, msgtype = match.groups()
        topics = [t for t in MSGTYPES if name in (t, f'/{t}') or name.endswith(f'/{t.lstrip("/")}') and name[0] == '/']
        return not topics or msgtype is not None and msgtype != MSGTYPES[topics[0]]
    node, parameter = match.group(1).rsplit('/', 1)[-1], match.group(2)
    return (COMMANDS.get(node, '').partition('.')[0] != 'nodes'
            or parameter not in {spec.name for spec in node_parameters(node)})


def ros2_commands(text: str) -> Iterator[re.Match[str]]:
    yield from TOPIC_COMMAND.finditer(text)
    yield from PARAM_COMMAND.finditer(text)


def test_every_ros2_command_of_the_docs_names_a_topic_or_parameter_of_the_suite() -> None:
    found = [(path, m) for path in [*MARKDOWN, *MODULES] for m in ros2_commands(path.read_text())]
    assert len(found) >= 5  # the README's own: echo, pub, param set, echo of a latched topic, ...
    stale = sorted(f'{path.relative_to(REPO)}: {m.group(0)}' for path, m in found if stale_ros2_command(m))
    assert stale == [], f'ros2 commands naming what the suite does not have: {stale}'


def test_the_ros2_command_check_tells_stale_commands_from_live_ones() -> None:
    for live in ('ros2 topic echo --once grasp/pose geometry_msgs/msg/PoseStamped', 'ros2 topic echo /diagnostics',
                 'ros2 topic pub --once /robot1/intent/w std_msgs/msg/Float64MultiArray',
                 'ros2 param set /robot1/model_server model', 'ros2 param describe /intent_interpreter task_names',
                 'ros2 topic pub --rate 2 --times 6 intent/w std_msgs/msg/Float64MultiArray'):
        assert [m for m in ros2_commands(live) if not stale_ros2_command(m)], live
    for stale in ('ros2 topic echo --once grasp/poses', 'ros2 topic pub --once intent/w std_msgs/msg/Float32MultiArray',
                  'ros2 topic pub --rate 2 intent/ww',
                  'ros2 topic echo robot1/intent/w', 'ros2 param set /model_server no_such_parameter',
                  'ros2 param set /no_such_node model', 'ros2 param get /suite model'):
        assert [m for m in ros2_commands(stale) if stale_ros2_command(m)], stale


def test_no_domain_id_the_docs_give_is_one_the_tests_claim() -> None:
    from grasp_intent_ros.launch.suite import TEST_DOMAIN_IDS
    texts = [*MARKDOWN, *MODULES, *(REPO / 'config').glob('*.yaml'),
             *(p for d in ('benchmarks', 'scripts') for p in (REPO / d).rglob('*.py'))]
    found = [(path, m) for path in texts for m in DOMAIN.finditer(path.read_text())]
    assert found
    clashing = sorted(f'{path.relative_to(REPO)}: {m.group(0)}' for path, m in found
                      if int(m.group(1)) in TEST_DOMAIN_IDS)
    assert clashing == [], f'example domain ids a running test may hold (use 91-101): {clashing}'


QUOTED = re.compile(r'`([<>\w/*]+)`')


def suite_topic(name: str) -> str | None:
    """The topic of the suite a quoted name is (``/cup/grasp/pose``, ``<object>/grasp/pose``, ``model/ambiguity*``).

    The longest trailing part of ``name`` that :data:`~grasp_intent_ros.wire.topics.MSGTYPES` holds, so a namespace
    or a chain's prefix before it does not matter; None when no part is a topic.
    """
    from grasp_intent_ros.wire.topics import MSGTYPES
    parts = name.rstrip('*').strip('/').split('/')
    for k in range(len(parts)):
        rest = '/'.join(parts[k:])
        for topic in (rest, f'/{rest}'):
            if topic in MSGTYPES:
                return topic
    return None


def message_types(text: str) -> list[str]:
    """The message types ``text`` names, as ``pkg/msg/Name``.

    Qualified (``std_msgs/String``, ``std_msgs/msg/String``) or bare as one of the suite's types
    (``Float64MultiArray``); a service type (``std_srvs``) is not a message's.
    """
    from grasp_intent_ros.wire.topics import MSGTYPES
    bare = {t.rsplit('/', 1)[1]: t for t in MSGTYPES.values()}
    pattern = rf'\b(\w+_msgs)/(?:msg/)?(\w+)|(?<![\w/])({"|".join(sorted(bare, key=len, reverse=True))})\b'
    return [f'{m.group(1)}/msg/{m.group(2)}' if m.group(1) else bare[m.group(3)] for m in re.finditer(pattern, text)]


def mistyped_topics(line: str) -> list[str]:
    """What a table row or a list item of the docs types wrongly.

    A type it names that none of its topics has; a type (a capitalised name) it gives a topic right after the topic's
    name (```intent/w` (Float64MultiArray: ...)``) that is not that topic's.
    """
    from grasp_intent_ros.wire.topics import MSGTYPES
    topics = {topic for m in QUOTED.finditer(line) if (topic := suite_topic(m.group(1)))}
    if not topics:
        return []
    theirs = {MSGTYPES[topic] for topic in topics}
    wrong = [f'{t} (the type of none of {sorted(topics)})' for t in message_types(line) if t not in theirs]
    for m in re.finditer(r'`([<>\w/*]+)` \((?:\w+_msgs/(?:msg/)?)?([A-Z][a-z]\w*)\b', line):
        topic = suite_topic(m.group(1))
        if topic and m.group(2) != MSGTYPES[topic].rsplit('/', 1)[1]:
            wrong.append(f'{m.group(1)} as {m.group(2)} (it is {MSGTYPES[topic]})')
    return wrong


def rows(path: Path) -> Iterator[tuple[int, str]]:
    """The table rows and list items of a Markdown page, with their line numbers."""
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if line.startswith('|') or re.match(r'\s*[-*] ', line):
            yield number, line


def test_every_type_the_docs_give_a_topic_is_its_type() -> None:
    wrong = [f'{path.relative_to(REPO)}:{number}: {problem}' for path in CURRENT_DOCS for number, line in rows(path)
             for problem in mistyped_topics(line)]
    assert wrong == [], f'topics given a type they do not have (wire/topics.py, MSGTYPES): {wrong}'


def test_the_topic_type_check_tells_wrong_types_from_right_ones() -> None:
    for right in ('| `intent_interpreter` | `intent/w` (Float64MultiArray: m task probabilities) | `intent/v` |',
                  '| mock_arm | in | `<object>/grasp/trajectory`, `assistance/object` | '
                  'trajectory_msgs/JointTrajectory; std_msgs/String |',
                  '- `/cup/grasp/pose`: a plan (geometry_msgs/msg/PoseStamped)',
                  '| assistance | service | `assistance/enable` | std_srvs/SetBool |'):
        assert mistyped_topics(right) == [], right
    for wrong in ('| `intent_interpreter` | `intent/w` (Float32MultiArray: m task probabilities) |',
                  '| assistance | out | `assistance/alpha` | std_msgs/Float64MultiArray |',
                  '- `grasp/pose` (JointState), `grasp/joint_targets` (PoseStamped)'):
        assert mistyped_topics(wrong), wrong


def node_side_topics() -> set[str]:
    """The topics of the suite that the nodes' side of the package names: those a node subscribes to or publishes.

    A topic of :data:`~grasp_intent_ros.wire.topics.MSGTYPES` whose constant a module of nodes/, ros/ or scene/
    uses.
    """
    from grasp_intent_ros.wire import topics
    sources = '\n'.join(p.read_text() for folder in ('nodes', 'ros', 'scene') for p in (PACKAGE / folder).glob('*.py'))
    return {topic for name in topics.__all__ if isinstance(topic := getattr(topics, name), str)
            and topic in topics.MSGTYPES and re.search(rf'\b{name}\b', sources)}


def test_every_topic_of_a_node_is_in_a_table_of_the_docs() -> None:
    tabled = {topic for path in CURRENT_DOCS for _, line in rows(path) if line.startswith('|')
              for m in QUOTED.finditer(line) if (topic := suite_topic(m.group(1)))}
    assert {'intent/w', 'grasp/pose', 'assistance/twist', '/diagnostics'} <= node_side_topics()
    assert sorted(node_side_topics() - tabled) == [], 'topics of the nodes that no topic table of the docs names'


def test_the_viewers_topic_table_is_what_it_follows() -> None:
    from grasp_intent_ros.scene.state import VIEWER_TOPICS
    text = (REPO / 'docs' / 'viewer.md').read_text()
    table = text.split('\n## What is shown, from which topic\n', 1)[1].split('\n## ', 1)[0]
    shown = {topic for line in table.splitlines() if line.startswith('|')
             for m in QUOTED.finditer(line) if (topic := suite_topic(m.group(1)))}
    assert shown == set(VIEWER_TOPICS), 'docs/viewer.md, "What is shown": the topics of scene.state.VIEWER_TOPICS'


@functools.cache
def node_services() -> dict[str, set[str]]:
    """Service name -> the types (``std_srvs/Trigger``) a node of nodes/ serves or calls it with.

    Read from each ``create_service(Type, name, ...)`` and ``create_client(Type, name)``: the name a string, a
    module-level constant of the package (``GRASP_CLOSE``, ``topics.ASSISTANCE_ENABLE``) or one of the names a
    comprehension runs over.
    """
    assignments = [(target.id, node.value) for path in MODULES for node in ast.parse(path.read_text()).body
                   if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None
                   for target in (node.targets if isinstance(node, ast.Assign) else [node.target])
                   if isinstance(target, ast.Name)]
    constants = {name: value.value for name, value in assignments
                 if isinstance(value, ast.Constant) and isinstance(value.value, str)}
    for name, value in assignments:  # aliases: ENABLE_SERVICE = topics.ASSISTANCE_ENABLE
        alias = value.id if isinstance(value, ast.Name) else value.attr if isinstance(value, ast.Attribute) else ''
        if alias in constants:
            constants[name] = constants[alias]
    services: dict[str, set[str]] = {}
    for path in (PACKAGE / 'nodes').glob('*.py'):
        tree = ast.parse(path.read_text())
        loops = {g.target.id: g.iter.elts for n in ast.walk(tree) if isinstance(n, (ast.ListComp, ast.DictComp))
                 for g in n.generators if isinstance(g.target, ast.Name) and isinstance(g.iter, ast.Tuple)}
        for call in ast.walk(tree):
            if not (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                    and call.func.attr in ('create_service', 'create_client') and len(call.args) >= 2
                    and isinstance(call.args[0], ast.Name)):
                continue
            name = call.args[1]
            for expr in loops.get(name.id, [name]) if isinstance(name, ast.Name) else [name]:
                key = expr.id if isinstance(expr, ast.Name) else expr.attr if isinstance(expr, ast.Attribute) else ''
                service = expr.value if isinstance(expr, ast.Constant) else constants.get(key)
                assert isinstance(service, str), f'nodes/{path.name}: a service name not read: {ast.unparse(expr)}'
                services.setdefault(service, set()).add(f'std_srvs/{call.args[0].id}')
    return services


def mistyped_services(line: str) -> list[str]:
    """The service types (``std_srvs/Trigger``) a docs row or list item names that none of its services has."""
    services = {name for name in re.findall(r'`([~\w/]+)`', line) if name in node_services()}
    theirs = {t for name in services for t in node_services()[name]}
    return [f'std_srvs/{t} (the type of none of {sorted(services)})'
            for t in re.findall(r'\bstd_srvs/(?:srv/)?(\w+)', line) if services and f'std_srvs/{t}' not in theirs]


def test_every_type_the_docs_give_a_service_is_its_type() -> None:
    assert {'assistance/enable': {'std_srvs/SetBool'}, 'grasp/close': {'std_srvs/Trigger'},
            'mock_arm/reset': {'std_srvs/Trigger'}}.items() <= node_services().items()  # a constant, an alias, a loop
    wrong = [f'{path.relative_to(REPO)}:{number}: {problem}' for path in CURRENT_DOCS for number, line in rows(path)
             for problem in mistyped_services(line)]
    assert wrong == [], f'services given a type they do not have: {wrong}'


def test_the_service_type_check_tells_wrong_types_from_right_ones() -> None:
    assert mistyped_services('| mock_arm | service | `~/reset`, `grasp/close` | std_srvs/Trigger |') == []
    assert mistyped_services('- `assistance/enable` (std_srvs/srv/SetBool): the switch') == []
    assert mistyped_services('| mock_arm | service | `grasp/close` | std_srvs/SetBool |')
    assert mistyped_services('- `assistance/enable` (std_srvs/Trigger)')


ROS_FREE_NODES = tuple(node for node in (*SUITE_NODES, *OPTIONAL_NODES)
                       if not table_name(node).startswith('grasp_intent_ros.nodes.'))
"""The nodes whose parameter tables this level reads (the viewer's is in its node module, which imports rclpy)."""
PAGE_NODES = {'nodes.md': SUITE_NODES, 'planner.md': ('grasp_planner',), 'intent_estimation.md': ('intent_estimator',),
              'shared_control.md': ('assistance', 'mock_arm', 'scripted_operator'),
              'several_objects.md': OPTIONAL_NODES, 'viewer.md': ('viewer',)}
"""The nodes whose parameters a page states (any other page: any node's)."""
UNITS = {'': 1.0, 'm': 1.0, 'cm': 1e-2, 'mm': 1e-3, 's': 1.0, 'ms': 1e-3, 'rad': 1.0, 'Hz': 1.0, 'kB': 1 << 10,
         'MB': 1 << 20, 'deg': math.pi / 180, 'degrees': math.pi / 180}
"""A unit the docs write -> its value in the code's unit (SI, radians, bytes)."""
VALUE = rf'(\d[\d,]*(?:\.\d+)?(?:e-?\d+)?)(?: ?({"|".join(u for u in UNITS if u)})\b)?'
STATED = re.compile(rf'`([\w.]+)`(?: = | \(| ){VALUE}|{VALUE}(?:[ \n][a-z][\w \n]{{0,30}}?)?[ \n]\(`([\w./]+)`\)')
"""A value the docs state for a name: ```standoff` = 8 cm``, ```yield_time` (0.15 s``, ``5 mm (`SWEEP_STEP`)``,
``1 kB (`ros/diagnostics.MAX_TEXT`)``."""


@functools.cache
def module_constants() -> dict[str, dict[str, float]]:
    """Every module-level UPPER_CASE number of the package (arithmetic on literals): name -> module -> value."""
    found: dict[str, dict[str, float]] = {}
    for path in MODULES:
        module = '.'.join(path.relative_to(PACKAGE).with_suffix('').parts).removesuffix('.__init__')
        for node in ast.parse(path.read_text()).body:
            value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign)) else None
            if value is None or not all(isinstance(n, (ast.Constant, ast.BinOp, ast.UnaryOp, ast.operator, ast.unaryop))
                                        for n in ast.walk(value)):
                continue
            number = eval(compile(ast.Expression(value), path.name, 'eval'), {'__builtins__': {}})
            if not isinstance(number, (int, float)) or isinstance(number, bool):
                continue
            for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                if isinstance(target, ast.Name) and target.id.isupper():
                    found.setdefault(target.id, {})[module] = number
    return found


@functools.cache
def numeric_defaults(node: str) -> dict[str, float]:
    """The numeric (not boolean) parameters of ``node`` and their defaults."""
    return {spec.name: spec.default for spec in node_parameters(node)
            if isinstance(spec.default, (int, float)) and not isinstance(spec.default, bool)}


def stated_values(page: str, text: str) -> Iterator[tuple[str, float, list[float]]]:
    """Each value ``text`` (of the page named ``page``) states for a constant or a numeric parameter.

    (What the page says, the value in the code's units, the code's values for that name); a dotted name picks the
    constant's module (``ros.run.SHUTDOWN_GRACE``), a parameter is one of the nodes the page documents.
    """
    for m in STATED.finditer(text):
        name, number, unit = m.group(1, 2, 3) if m.group(1) else m.group(6, 4, 5)
        module, _, last = name.replace('/', '.').rpartition('.')
        if last.isupper():
            code = [value for where, value in module_constants().get(last, {}).items()
                    if not module or where == module or where.endswith(f'.{module}')]
        else:
            code = [numeric_defaults(node)[name] for node in PAGE_NODES.get(page, ROS_FREE_NODES)
                    if node in ROS_FREE_NODES and name in numeric_defaults(node)]
        if code:
            yield m.group(0).replace('\n', ' '), float(number.replace(',', '')) * UNITS[unit or ''], code


def test_every_value_the_docs_state_for_a_constant_or_parameter_is_the_codes() -> None:
    found = [(path, said, value, code) for path in CURRENT_DOCS
             for said, value, code in stated_values(path.name, path.read_text())]
    assert len(found) >= 40  # standoff, corridor_radius, yield_time, TURN_SLACK, SWEEP_STEP, MAX_CHECKED, ...
    wrong = [f'{path.relative_to(REPO)}: {said!r} is {value:g}, the code has {code}'
             for path, said, value, code in found if not any(math.isclose(value, c, rel_tol=1e-9) for c in code)]
    assert wrong == [], f'values the docs state that the code does not have: {wrong}'


def test_the_stated_value_check_reads_units_and_names() -> None:
    text = ('`standoff` = 8 cm; at least 5 mm\n(`SWEEP_STEP`); the 8 shortest candidates (`MAX_CHECKED`); '
            '`yield_time` (0.2 s) and 1 s (`ros.run.SHUTDOWN_GRACE`); `no_such_name` (3 s); `period` (0.01 s)')
    assert {said: (value, code) for said, value, code in stated_values('shared_control.md', text)} == {
        '`standoff` = 8 cm': (0.08, [0.08]), '5 mm (`SWEEP_STEP`)': (0.005, [0.005]),
        '8 shortest candidates (`MAX_CHECKED`)': (8.0, [8]), '`yield_time` (0.2 s': (0.2, [0.15]),
        '1 s (`ros.run.SHUTDOWN_GRACE`)': (1.0, [5.0]), '`period` (0.01 s': (0.01, [0.01])}
    assert list(stated_values('intent_estimation.md', '`period` (0.01 s)')) == []  # not the estimator's parameter
    assert [v for _, v, _ in stated_values('nodes.md', 'capped at 1 kB (`ros/diagnostics.MAX_TEXT`)')] == [1024.0]


CAPS = re.compile(r'(\d+) (kB|MB) on ((?:`[\w/]+`(?:,? (?:and )?)?)+)')
"""A size cap the docs state for topics: ``64 kB on `intent/v`, `model/query` and `joint_states```."""


def wrong_caps(text: str) -> list[str]:
    """The topics whose cap ``text`` states otherwise than :data:`~grasp_intent_ros.wire.topics.MAX_MESSAGE_BYTES`.

    A cap is stated in whole kB or MB (1024 and 1024^2 bytes), the code's rounded to the nearest.
    """
    from grasp_intent_ros.wire.topics import MAX_MESSAGE_BYTES
    wrong = []
    for m in CAPS.finditer(' '.join(text.split())):
        for topic in re.findall(r'`([\w/]+)`', m.group(3)):
            cap = MAX_MESSAGE_BYTES.get(suite_topic(topic) or topic)
            if cap is None or round(cap / UNITS[m.group(2)]) != int(m.group(1)):
                wrong.append(f'{topic}: {m.group(1)} {m.group(2)} (the code: {cap} bytes)')
    return wrong


def test_every_size_cap_the_docs_state_is_the_codes() -> None:
    text = (REPO / 'docs' / 'nodes.md').read_text()
    assert len(CAPS.findall(' '.join(text.split()))) >= 5
    assert [problem for path in CURRENT_DOCS for problem in wrong_caps(path.read_text())] == []


def test_the_size_cap_check_tells_wrong_caps_from_right_ones() -> None:
    assert wrong_caps('16 kB on `intent/w`,\n4 kB on `object/pose`, 64 kB on `intent/v`, `model/query` and\n'
                      '`joint_states`, 4 MB on `model/active`') == []
    assert len(wrong_caps('32 kB on `intent/w`, 64 kB on `object/pose` and `joint_states`, 4 kB on `no/topic`')) == 3


CONFIG_CHANGES = {('mock_arm', 'trajectory_execution'): 'on_request'}
"""(node, parameter) -> the value its config/<node>.yaml sets instead of the default: in the suite's shared-control
loop the twists own the arm (docs/shared_control.md)."""


def test_every_config_file_sets_its_nodes_defaults_but_the_documented_changes() -> None:
    import yaml
    changed = {}
    for node in ROS_FREE_NODES:
        (section,) = yaml.safe_load((REPO / 'config' / f'{node}.yaml').read_text()).values()
        for spec in node_parameters(node):  # a parameter the file lacks: test/ros/test_config_files.py says so
            default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
            if (value := section['ros__parameters'].get(spec.name, default)) != default:
                changed[node, spec.name] = value
    assert changed == CONFIG_CHANGES, 'a config file sets a value other than the default: say so (CONFIG_CHANGES)'
    for (node, name), value in CONFIG_CHANGES.items():
        page = next(page for page, nodes in PAGE_NODES.items() if node in nodes)
        assert f'`{name}: {value}`' in (REPO / 'docs' / page).read_text(), f'docs/{page}: config/{node}.yaml sets it'


OPTIONS = re.compile(rf'(?:{COMMAND.pattern}|((?:benchmarks|scripts)/\w+\.(?:py|sh)|\b\w+\.py))([^\n`#]*)')
"""A command, a benchmark or a script of scripts/, then what follows it on its line up to a quote's end or a
comment."""


def parser_sources(module: Path) -> str:
    """``module``'s source and that of the package modules it imports, where its parser's options are defined."""
    tree = ast.parse(module.read_text())
    sources = [module.read_text()]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.level or (node.module or '').startswith('grasp_intent_ros')):
            base = module.parents[node.level - 1] if node.level else REPO
            base = base.joinpath(*(node.module or '').split('.'))
            for alias in node.names:
                for path in (base / f'{alias.name}.py', base.with_suffix('.py'), base / '__init__.py'):
                    if path.is_file():
                        sources.append(path.read_text())
                        break
    return '\n'.join(sources)


def unknown_options(match: re.Match[str]) -> list[str]:
    """The ``--options`` after a command, benchmark or script that it does not define (any but ROS's own).

    A Python command line defines an option its parser names (``'--check'``); a shell script one its text names
    (its usage comment says what it passes on, e.g. ``scripts/lock.sh --upgrade`` to uv).
    """
    from grasp_intent_ros.commands import COMMANDS
    command, script, rest = match.groups()
    options = re.findall(r'(?<![\w-])(--[a-z][\w-]*)', rest.split('--ros-args')[0])
    if command is not None:
        if command not in COMMANDS:
            return []  # test_every_reference_to_the_package_names_what_exists names it
        source = parser_sources(PACKAGE.joinpath(*COMMANDS[command].split('.')).with_suffix('.py'))
    else:
        path = REPO / script if '/' in script else REPO / 'benchmarks' / script
        if not path.is_file():
            return []
        if path.suffix == '.sh':
            return [option for option in options if not re.search(rf'(?<![\w-]){option}(?![\w-])', path.read_text())]
        helpers = (REPO / 'benchmarks' / '_bench').glob('*.py')  # the benchmarks' shared options
        source = '\n'.join([parser_sources(path), *(p.read_text() for p in helpers)])
    return [option for option in options if f"'{option}'" not in source]


def test_every_option_the_docs_give_a_command_is_one_it_takes() -> None:
    found = [(path, m) for path in [*TEXTS, REPO / 'CONTRIBUTING.md'] for m in OPTIONS.finditer(path.read_text())]
    assert len(found) >= 20
    unknown = sorted({f'{path.relative_to(REPO)}: {m.group(0).strip()} ({", ".join(bad)})' for path, m in found
                      if (bad := unknown_options(m))})
    assert unknown == [], f'options no parser defines (renamed or dropped?): {unknown}'


def test_the_option_check_tells_unknown_options_from_known_ones() -> None:
    for known in ('python -m grasp_intent_ros replay BAG --check --start-suite --ros-args --log-level debug',
                  'python -m grasp_intent_ros recorder my_session --topics intent/ --flush-period 1',
                  'benchmarks/bench_shutdown.py --suite [--together]', './scripts/test.sh --other-cpu [test/unit]',
                  'scripts/venv.sh --latest'):
        assert [m for m in OPTIONS.finditer(known) if not unknown_options(m)], known
    for unknown in ('python -m grasp_intent_ros replay BAG --checks', 'grasp-intent-ros train x.csv --zone 7zone',
                    'bench_task_success.py --physic', 'scripts/test.sh --other-cpus', 'scripts/venv.sh --lattest'):
        assert [m for m in OPTIONS.finditer(unknown) if unknown_options(m)], unknown


def test_the_readmes_library_example_runs() -> None:
    text = (REPO / 'README.md').read_text()
    blocks = re.findall(r'^```python\n(.*?)^```', text, re.MULTILINE | re.DOTALL)
    assert len(blocks) == 1
    names: dict[str, object] = {}
    exec(compile(blocks[0], 'README.md', 'exec'), names)  # noqa: S102 - the README's own example
    assert names['res'].status == names['robust'].status == names['paper'].status == 'ok'  # type: ignore[attr-defined]
    assert names['kl'].shape == (3, 3)  # type: ignore[attr-defined]


def report_outputs() -> list[str]:
    """The files ``report`` writes, as the entries of :mod:`grasp_intent_ros.sessions.report`'s docstring name them."""
    doc = ast.get_docstring(ast.parse((PACKAGE / 'sessions' / 'report.py').read_text())) or ''
    return re.findall(r'^``([\w.\[\]<>]+\.(?:png|md))``', doc, re.MULTILINE)


def test_the_sessions_page_names_every_file_the_report_writes() -> None:
    outputs = report_outputs()
    assert {'summary.md', 'shared_control.png', 'grasp_scene_<k>.png'} <= set(outputs)  # the docstring's entries
    text = (REPO / 'docs' / 'sessions.md').read_text()
    section = text.split('\n## report\n', 1)[1].split('\n## ', 1)[0]
    assert [name for name in outputs if f'`{name}`' not in section] == [], 'docs/sessions.md, "report"'
