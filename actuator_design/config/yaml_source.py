"""Reading a configuration file with bounded cost: size, nesting, aliases and duplicate keys.

A configuration is small (a few kB, nesting depth < 10). A hostile file must fail fast with one line
instead of exhausting memory or time, so reading is bounded:

* the file is at most :data:`MAX_FILE_BYTES` (1 MiB) and must be UTF-8 text;
* mappings and lists nest at most :data:`MAX_DEPTH` deep;
* at most :data:`MAX_ALIASES` aliases (``*name``), and the document expanded through its aliases
  has at most :data:`MAX_NODES` values (an "alias bomb" of nested aliases is a few lines of YAML
  that expand to billions of values);
* a key given twice in one mapping is an error naming the key and both lines (YAML would silently
  keep the last).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from yaml.events import AliasEvent

from actuator_design.config.errors import ConfigError, dotted

__all__ = ["MAX_FILE_BYTES", "MAX_DEPTH", "MAX_ALIASES", "MAX_NODES", "read_yaml", "check_structure"]

MAX_FILE_BYTES = 1 << 20
MAX_DEPTH = 64
MAX_ALIASES = 100
MAX_NODES = 100_000

_MERGE_TAG = "tag:yaml.org,2002:merge"


class _BoundedLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that limits nesting depth and aliases and rejects duplicate keys."""

    def __init__(self, stream, source: str):
        super().__init__(stream)
        self._source, self._depth, self._aliases = source, 0, 0

    def compose_node(self, parent, index):
        if self.check_event(AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                line = self.peek_event().start_mark.line + 1
                raise ConfigError("config", f"more than {MAX_ALIASES} YAML aliases in {self._source} "
                                            f"(line {line})")
        self._depth += 1
        if self._depth > MAX_DEPTH:
            line = self.peek_event().start_mark.line + 1
            raise ConfigError("config", f"nesting deeper than {MAX_DEPTH} levels in {self._source} "
                                        f"(line {line})")
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            first_line = {}
            for key_node, _ in node.value:
                if key_node.tag == _MERGE_TAG or not isinstance(key_node, yaml.ScalarNode):
                    continue
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                if key in first_line:
                    raise ConfigError("config", f"duplicate key '{str(key)[:80]}' at line {line} of "
                                                f"{self._source} (first given at line {first_line[key]})")
                first_line[key] = line
        return super().construct_mapping(node, deep)


def read_yaml(path: Path) -> Any:
    """The YAML document in ``path`` as Python data, read within the bounds above.

    Raises
    ------
    ConfigError
        ``config: <problem> <file> ...`` for a missing, unreadable, oversized, non-UTF-8 or invalid
        file, and for a document that nests, aliases or repeats keys beyond the bounds.
    """
    try:
        with path.open("rb") as stream:  # a bounded read: /dev/zero or a FIFO must not hang us
            raw = stream.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise ConfigError("config", f"file not found: {path}") from None
    except OSError as err:
        raise ConfigError("config", f"cannot read {path}: {err.strerror or err}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ConfigError("config", f"{path} is larger than {MAX_FILE_BYTES} bytes (1 MiB), the most a "
                                    "configuration may have")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise ConfigError("config", f"{path} is not UTF-8 text (byte 0x{raw[err.start]:02x} at offset "
                                    f"{err.start})") from None
    loader = _BoundedLoader(text, str(path))
    try:
        data = loader.get_single_data()
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        problem = getattr(err, "problem", None) or str(err)
        raise ConfigError("config", f"invalid YAML in {path}{where}: {problem}") from None
    except RecursionError:
        raise ConfigError("config", f"nesting too deep in {path}") from None
    finally:
        loader.dispose()
    check_structure(data, str(path))
    return data


def check_structure(data: Any, source: str = "the configuration") -> None:
    """Check that ``data`` (dicts, lists, scalars), expanded through shared references, has at most
    :data:`MAX_NODES` values and nests at most :data:`MAX_DEPTH` deep; stops at the first excess.

    Raises
    ------
    ConfigError
        Naming the dotted path where the bound was exceeded.
    """
    count, stack = 0, [(data, ())]
    while stack:
        obj, path = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise ConfigError("config", f"{source} expands to more than {MAX_NODES} values (YAML "
                                        f"aliases?); stopped at {dotted(path)[:120]}")
        if len(path) > MAX_DEPTH:
            raise ConfigError(dotted(path[:4]) + "...", f"nesting deeper than {MAX_DEPTH} levels in "
                                                        f"{source}")
        if isinstance(obj, dict):
            stack.extend((v, path + (k,)) for k, v in obj.items())
        elif isinstance(obj, list):
            stack.extend((v, path + (i,)) for i, v in enumerate(obj))
