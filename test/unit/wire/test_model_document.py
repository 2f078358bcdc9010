"""grasp_intent_ros.wire.model_document: the document written, read back, and refused when malformed."""

from __future__ import annotations

import hashlib

import pytest

from grasp_intent_ros.errors import ModelFormatError
from grasp_intent_ros.method.model import GraspModel
from grasp_intent_ros.method.safe_yaml import MAX_DOCUMENT_CHARS
from grasp_intent_ros.wire.model_document import (
    ModelHeader,
    model_document,
    parse_model_document,
    read_model_document,
)


def test_model_document_round_trip(toy_model: GraspModel) -> None:
    text = model_document(toy_model, name='cup_7zone', version=3)
    body = toy_model.to_yaml()
    sha = hashlib.sha256(body.encode()).hexdigest()
    assert text == f'# model_name: cup_7zone\n# model_version: 3\n# model_sha256: {sha}\n{body}'
    assert parse_model_document(text) == (ModelHeader('cup_7zone', 3, sha), body)
    assert GraspModel.from_yaml(text).to_yaml() == body  # the header lines are YAML comments
    for name, version in (('two\nlines', 1), ('m', 0)):
        with pytest.raises(ValueError, match='one line'):
            model_document(toy_model, name=name, version=version)


def test_malformed_model_documents_raise(toy_model: GraspModel) -> None:
    text = model_document(toy_model, name='m', version=1)
    with pytest.raises(ModelFormatError, match='lacks the header lines'):
        parse_model_document(toy_model.to_yaml())
    with pytest.raises(ModelFormatError, match='lacks the header lines'):
        parse_model_document(text.replace('# model_version: 1', '# model_version: one'))
    corrupted = text.replace('prior: 0.', 'prior: 1.', 1)
    with pytest.raises(ModelFormatError, match='corrupted'):
        parse_model_document(corrupted)
    assert parse_model_document(corrupted, check_sha256=False)[0] == parse_model_document(text)[0]
    with pytest.raises(ModelFormatError, match='model_version must be >= 1'):
        parse_model_document(text.replace('# model_version: 1', '# model_version: 0'))


def test_whole_document_is_read_into_a_model(toy_model: GraspModel) -> None:
    doc = read_model_document(model_document(toy_model, name='toy', version=2))
    assert (doc.name, doc.version) == ('toy', 2) and isinstance(doc, ModelHeader)
    assert doc.model.to_yaml() == toy_model.to_yaml()
    again = read_model_document(model_document(toy_model, name='toy', version=3), previous=doc)
    assert (again.version, again.sha256) == (3, doc.sha256) and again.model is doc.model  # not parsed again
    renamed = read_model_document(model_document(toy_model, name='toy2', version=4), previous=doc)
    assert renamed.model is not doc.model and renamed.model.to_yaml() == toy_model.to_yaml()
    with pytest.raises(ModelFormatError, match='corrupted'):  # the reuse still checks the hash
        read_model_document(model_document(toy_model, name='toy', version=5).replace('prior: 0.', 'prior: 1.', 1),
                            previous=doc)


def test_oversized_document_is_rejected_before_the_header_is_read(toy_model: GraspModel) -> None:
    text = model_document(toy_model, name='toy', version=1)
    oversized = text + '#' * (MAX_DOCUMENT_CHARS + 1 - len(text))
    for reader in (parse_model_document, read_model_document):
        with pytest.raises(ModelFormatError, match='oversized'):
            reader(oversized)
        with pytest.raises(ModelFormatError, match='oversized'):
            reader('no header' + ' ' * MAX_DOCUMENT_CHARS)
