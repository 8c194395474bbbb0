"""YAML files read like ``yaml.safe_load``, but without aliases, and errors as one line.

Configs (:mod:`wheelgym.agents.config`) and map files (:mod:`wheelgym.world.maps`) are read
here. Aliases (``*name``, merge keys ``<<: *x`` included) are refused: neither kind of file needs
them, and nested aliases expand exponentially (nine levels of nine aliases walk 9^10 nodes).
Nothing is evaluated (``SafeLoader``'s tags only).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

__all__ = ["AliasError", "load", "one_line"]


def one_line(text: Any) -> str:
    """``text`` with every run of white space (newlines too) folded to one space."""
    return " ".join(str(text).split())


class AliasError(yaml.composer.ComposerError):
    """An alias met where the value of ``field`` (a key, ``[index]`` or ``<key>``) stands."""

    def __init__(self, field: str, anchor: str, mark: Any) -> None:
        super().__init__(None, None, f"YAML aliases are not allowed (found *{anchor}; write the "
                         "value out instead)", mark)
        self.field = field


class _NoAliasSafeLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that refuses aliases, so no document can expand."""

    def compose_node(self, parent, index):  # type: ignore[override]
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            # a mapping's value is composed with its key node as index, a list item with its
            # position: name what the alias stands for
            if isinstance(index, yaml.ScalarNode):
                field = str(index.value)
            elif isinstance(index, int):
                field = f"[{index}]"
            else:
                field = "<key>"
            raise AliasError(field, str(event.anchor), event.start_mark)
        return super().compose_node(parent, index)


def _message(e: yaml.YAMLError) -> str:
    """A YAML error as one line: what went wrong and where (no source snippet)."""
    if isinstance(e, yaml.MarkedYAMLError):
        what = "; ".join(one_line(x) for x in (e.context, e.problem) if x) or "syntax error"
        mark = e.problem_mark or e.context_mark
        if mark is not None:
            what += f" (line {mark.line + 1}, column {mark.column + 1})"
        return what
    return one_line(e)


def load(path: str | Path, what: str = "file") -> Any:
    """The document of the YAML file ``path``.

    Raises:
        ValueError: one line starting with the path: the file cannot be read (``what`` names
            it, e.g. ``"config"``), is not valid YAML, or holds an alias (naming the field).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ValueError(one_line(f"{path}: cannot read {what}: {e}")) from None
    loader = _NoAliasSafeLoader(text)
    try:
        return loader.get_single_data()
    except AliasError as e:
        raise ValueError(one_line(f"{path}: field {e.field!r}: {_message(e)}")) from None
    except yaml.YAMLError as e:
        raise ValueError(one_line(f"{path}: not valid YAML: {_message(e)}")) from None
    except RecursionError:  # deeply nested flow collections
        raise ValueError(f"{path}: not valid YAML: nested too deeply") from None
    finally:
        loader.dispose()
