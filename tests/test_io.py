"""Atomic writes: complete, readable files or the old file, never a mix."""

from __future__ import annotations

from pathlib import Path

import pytest


def test_atomic_writes_leave_readable_complete_files(tmp_path: Path) -> None:
    from noisybolt.io import atomic_open, atomic_write_json

    target = tmp_path / "out.json"
    atomic_write_json(target, {"a": 1})
    assert target.stat().st_mode & 0o777 == 0o644
    with pytest.raises(RuntimeError), atomic_open(target, "w") as handle:
        handle.write("half")
        raise RuntimeError("killed mid-write")
    assert target.read_text() == '{\n  "a": 1\n}\n'  # the old file, intact
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]  # no temp file left
