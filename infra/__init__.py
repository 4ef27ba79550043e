"""What every layer stands on and none of the physics: the one input error, atomic file
writing, lazy public names, the TOML schema and writer the config files are declared with,
and the progress of long work.

- rsp_inertia.infra.errors: :class:`InputError`, the one exception for bad input;
- rsp_inertia.infra.files: atomic writes, the check that an output can be written, sha256;
- rsp_inertia.infra.frozen: read-only arrays for the frozen records;
- rsp_inertia.infra.lazy: the packages' PEP 562 loader of their public names;
- rsp_inertia.infra.toml_schema, rsp_inertia.infra.toml_writer: config classes whose fields
  declare a TOML file's keys, their reader and their writer;
- rsp_inertia.infra.progress: the progress of long work, shown on a terminal.

It imports nothing else of the package.
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

_HOMES = {
    "InputError": "errors",
    "check_writable": "files",
    "file_sha256": "files",
    "freeze_arrays": "frozen",
    "read_only": "frozen",
    "write_atomic": "files",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "InputError",
    "check_writable",
    "file_sha256",
    "freeze_arrays",
    "read_only",
    "write_atomic",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
