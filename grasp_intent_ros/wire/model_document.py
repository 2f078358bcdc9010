"""The model document (``model/active``, std_msgs/String): written, read and validated.

Three header lines (model name, version, sha256 of the YAML that follows), then the YAML of
:meth:`~grasp_intent_ros.method.model.GraspModel.to_yaml` (:func:`model_document`). ``model_version``
counts activations in one model server (1 = the first model it published); it restarts at 1 when the
server restarts. ``model_sha256`` identifies the content: a consumer that must know whether the model
changed compares (name, sha256); to order documents from one server it compares versions.
A document holds at most :data:`~grasp_intent_ros.method.safe_yaml.MAX_DOCUMENT_CHARS` characters (checked on
the raw text before the header is matched or the body hashed) and its YAML no alias (``*name``): readers
reject both (:meth:`~grasp_intent_ros.method.model.GraspModel.from_yaml`). ROS-free.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass

from ..errors import ModelError, ModelFormatError
from ..method.model import GraspModel, ModelRequirements
from ..method.safe_yaml import check_document_size

__all__ = ['ModelHeader', 'ModelDocument', 'model_document', 'parse_model_document', 'read_model_document']

@dataclass(frozen=True)
class ModelHeader:
    """The header of a model document.

    Attributes
    ----------
    name : str
        The model's name (the model server's ``model`` parameter).
    version : int
        Activation count in the publishing model server, >= 1.
    sha256 : str
        Hex digest of the YAML body.
    """

    name: str
    version: int
    sha256: str


@dataclass(frozen=True)
class ModelDocument(ModelHeader):
    """A model as published on ``model/active``: its header (name, version, content hash) and the model."""

    model: GraspModel


_HEADER = re.compile(r'# model_name: (?P<name>[^\n]*)\n# model_version: (?P<version>[0-9]+)\n'
                     r'# model_sha256: (?P<sha>[0-9a-f]{64})\n')


def model_document(model: GraspModel, *, name: str, version: int) -> str:
    """The versioned model document: three header lines, then :meth:`GraspModel.to_yaml`.

    ::

        # model_name: cup_7zone
        # model_version: 3
        # model_sha256: <sha256 of the YAML text that follows, hex>
        <GraspModel YAML>

    The header lines are YAML comments, so :meth:`GraspModel.from_yaml` also reads the whole text.

    Raises
    ------
    ValueError
        If ``name`` spans several lines or ``version < 1``.
    """
    if '\n' in name or version < 1:
        raise ValueError('name must be one line and version >= 1')
    body = model.to_yaml()
    sha = hashlib.sha256(body.encode()).hexdigest()
    return f'# model_name: {name}\n# model_version: {version}\n# model_sha256: {sha}\n{body}'


def parse_model_document(text: str, *, check_sha256: bool = True) -> tuple[ModelHeader, str]:
    """Split a document written by :func:`model_document` into its header and YAML body.

    The body is not parsed (see :func:`read_model_document`). ``check_sha256=False`` reads the header
    alone, without hashing the body.

    Raises
    ------
    ModelFormatError
        If the text is oversized (:data:`~grasp_intent_ros.method.safe_yaml.MAX_DOCUMENT_CHARS`, checked
        first), the header lines are missing or malformed, ``model_version < 1``, or (when checked) the
        body's sha256 differs from the header's.
    """
    check_document_size(text)
    header = _HEADER.match(text)
    if header is None:
        raise ModelFormatError('model document lacks the header lines "# model_name: ...", '
                               '"# model_version: <n>", "# model_sha256: <hex>"')
    body = text[header.end():]
    if check_sha256:
        sha = hashlib.sha256(body.encode()).hexdigest()
        if sha != header['sha']:
            raise ModelFormatError(f'model document is corrupted: sha256 {sha} does not match the header')
    version = int(header['version'])
    if version < 1:
        raise ModelFormatError(f'model_version must be >= 1, got {version}')
    return ModelHeader(header['name'], version, header['sha']), body


def read_model_document(text: str, *, previous: ModelDocument | None = None,
                        requires: ModelRequirements | None = None) -> ModelDocument:
    """Parse a whole model document: header checked, body read by :meth:`GraspModel.from_yaml`.

    When ``previous`` has the same name and sha256 as ``text`` (a model re-latched, e.g. by a restarted
    model server), its model is reused: the body is hashed, not parsed again. ``requires`` refuses a valid
    model the reader cannot serve, by its declaration, before the document's arrays are parsed.

    Raises
    ------
    ModelError
        If ``requires`` refuses the model (the message names the model).
    ModelFormatError
        If the text is oversized, the header is missing or malformed, the hash does not match the YAML,
        or the YAML is not a valid model (an alias or too deep a nesting included).
    """
    header, body = parse_model_document(text)
    same = previous is not None and (previous.name, previous.sha256) == (header.name, header.sha256)
    try:
        if previous is not None and same:
            model = previous.model
            if requires is not None:
                requires.check(model.task_names, model.feature_names)
        else:
            model = GraspModel.from_yaml(body, requires=requires)
    except ModelFormatError:
        raise
    except ModelError as exc:
        raise ModelError(f'model {header.name[:64]!r} refused: {exc}') from None
    return ModelDocument(header.name, header.version, header.sha256, model)
