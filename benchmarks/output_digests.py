"""Digests of every table the README's commands and ``longprofile demo`` write: a refactoring must not change them.

Runs, in a fresh temporary folder, every ``sh`` command of the README (as ``tests/test_readme.py`` does) and then
``longprofile demo -o demo``, and records a SHA-256 per written data file:

* CSV, ERD, JSON, TXT: the bytes, with lines that name a version or a creation time left out (``longprofile``
  version, ``created``/``generated``/``timestamp`` keys) — those change from commit to commit by design;
* Parquet: the table's columns (values, names, types) via pyarrow, not the file bytes (the writer's footer names
  its version), plus the longprofile metadata keys other than version and time.

PNG, HTML and SQLite files are not compared (fonts, embedded times, page layout are not numbers).

Use::

    .venv/bin/python -m benchmarks.output_digests before.json --src /path/to/old/checkout/src --keep before/
    .venv/bin/python -m benchmarks.output_digests after.json --compare before.json --keep after/

A file whose digest differs is then compared as numbers when both folders are kept: the largest absolute
difference of each numeric column, relative to the column's RMS. Freshly compiled numba kernels and kernels loaded
from numba's disk cache can differ in the last bits (vectorised reductions), so run each side twice (the second run
on a warm cache) before calling a difference a change.

``--src`` puts another source tree first on ``PYTHONPATH`` (the installed venv is otherwise the same), so the two
runs differ only by the code under test.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_VOLATILE = re.compile(r"(version|created|generated|timestamp|elapsed|seconds|wall|_ts\b|_at\b)", re.I)
_DATA_SUFFIXES = {".csv", ".erd", ".json", ".txt", ".parquet", ".toml"}


def readme_commands(readme: Path) -> list[str]:
    """The README's shell commands, as ``tests/test_readme.py`` runs them."""
    blocks = re.findall(r"^```sh\n(.*?)^```", readme.read_text(), flags=re.S | re.M)
    cmds = []
    for block in blocks:
        block = re.sub(r"\\\n\s*", " ", block)
        cmds += [ln.strip() for ln in block.splitlines() if ln.strip() and not ln.strip().startswith("#")]
    return [c for c in cmds if c != "source .venv/bin/activate"]


def _strip_volatile(obj):
    if isinstance(obj, dict):
        return {k: _strip_volatile(v) for k, v in obj.items() if not _VOLATILE.search(str(k))}
    if isinstance(obj, list):
        return [_strip_volatile(v) for v in obj]
    return obj


def _digest_text(path: Path, workdir: Path) -> str:
    data = path.read_bytes().replace(str(workdir).encode(), b"<WORKDIR>")
    if path.suffix.lower() == ".json":
        try:
            return hashlib.sha256(json.dumps(_strip_volatile(json.loads(data)), sort_keys=True).encode()).hexdigest()
        except ValueError:
            pass
    lines = data.splitlines(keepends=True)
    kept = [ln for ln in lines if not _VOLATILE.search(ln.decode("utf-8", "replace"))]
    return hashlib.sha256(b"".join(kept)).hexdigest()


def _digest_parquet(path: Path, workdir: Path) -> str:
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    h = hashlib.sha256()
    for name, col in zip(table.column_names, table.columns):
        h.update(name.encode())
        h.update(str(col.type).encode())
        if pa.types.is_string(col.type) or pa.types.is_large_string(col.type):
            if _VOLATILE.search(name):
                continue
            col = pc.replace_substring(col, str(workdir), "<WORKDIR>")
        for chunk in col.chunks:
            for buf in chunk.buffers():
                if buf is not None:
                    h.update(buf.to_pybytes())
    meta = table.schema.metadata or {}
    for key in sorted(meta):
        if not _VOLATILE.search(key.decode("utf-8", "replace")):
            value = meta[key]
            try:  # JSON metadata: drop volatile keys inside
                obj = json.loads(value)
                if isinstance(obj, dict):
                    obj = {k: v for k, v in obj.items() if not _VOLATILE.search(k)}
                value = json.dumps(obj, sort_keys=True).encode()
            except (ValueError, TypeError):
                pass
            h.update(key + b"=" + value)
    return h.hexdigest()


def digests(folder: Path, workdir: Path | None = None) -> dict[str, str]:
    """Digest of every data file under ``folder``; ``workdir`` (default: ``folder``) is the folder the commands ran
    in, replaced by a placeholder wherever a file records an absolute path."""
    workdir = folder if workdir is None else workdir
    out = {}
    for p in sorted(folder.rglob("*")):
        if not p.is_file() or p.suffix.lower() not in _DATA_SUFFIXES or "__pycache__" in p.parts:
            continue
        rel = str(p.relative_to(folder))
        if rel.startswith("readme_snippet"):
            continue
        out[rel] = _digest_parquet(p, workdir) if p.suffix.lower() == ".parquet" else _digest_text(p, workdir)
    return out


def _read_numbers(path: Path):
    import pandas as pd

    if path.suffix.lower() == ".parquet":
        return pd.read_parquet(path)
    if path.suffix.lower() == ".csv":
        return pd.read_csv(path, comment="#")
    return None


def numeric_difference(a: Path, b: Path, root_a: Path | None = None, root_b: Path | None = None) -> float | None:
    """Largest |a - b| / RMS(a) over the numeric columns of two tables (None when not comparable as numbers)."""
    import numpy as np
    import pandas as pd

    try:
        ta, tb = _read_numbers(a), _read_numbers(b)
    except Exception:
        return None
    if ta is None or tb is None or list(ta.columns) != list(tb.columns) or len(ta) != len(tb):
        return None
    worst = 0.0
    for col in ta.columns:
        x, y = ta[col], tb[col]
        if not (pd.api.types.is_numeric_dtype(x) and pd.api.types.is_numeric_dtype(y)) or x.dtype == bool:
            xs, ys = x.astype(str), y.astype(str)
            if root_a is not None and root_b is not None:
                xs, ys = xs.str.replace(str(root_a), "<WORKDIR>"), ys.str.replace(str(root_b), "<WORKDIR>")
            if not xs.equals(ys) and not _VOLATILE.search(str(col)):
                return None
            continue
        x, y = x.to_numpy(float), y.to_numpy(float)
        if not np.array_equal(np.isnan(x), np.isnan(y)):
            return None
        ok = ~np.isnan(x)
        if ok.any():
            rms = float(np.sqrt(np.mean(x[ok] ** 2))) or 1.0
            worst = max(worst, float(np.max(np.abs(x[ok] - y[ok]))) / rms)
    return worst


def run(src: Path | None, workdir: Path) -> dict[str, str]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    if src is not None:
        env["PYTHONPATH"] = f"{src}{os.pathsep}{env.get('PYTHONPATH', '')}"
    for cmd in readme_commands(ROOT / "README.md") + ["longprofile demo -o demo"]:
        proc = subprocess.run(["bash", "-c", cmd], cwd=workdir, env=env, capture_output=True, text=True, timeout=900)
        if proc.returncode != 0:
            raise SystemExit(f"command failed (exit {proc.returncode}): {cmd}\n{proc.stderr[-2000:]}")
    return digests(workdir)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("output", type=Path, help="JSON file of digests to write")
    ap.add_argument("--src", type=Path, help="source tree to test instead of the installed one")
    ap.add_argument("--compare", type=Path, help="digests of an earlier run: print the differences, exit 1 if any")
    ap.add_argument("--keep", type=Path, help="keep the written files in this (new) folder")
    ap.add_argument("--folder", type=Path, help="do not run anything: digest this kept folder again")
    args = ap.parse_args(argv)
    for p in (args.output, args.keep):
        if p is not None and p.exists():
            raise SystemExit(f"{p} exists; choose another name")
    if args.folder:
        result = digests(args.folder.resolve())
        args.keep = args.folder
    elif args.keep:
        args.keep.mkdir(parents=True)
        args.keep = args.keep.resolve()
        result = run(args.src, args.keep)
    else:
        with tempfile.TemporaryDirectory(prefix="lp-digests-") as tmp:
            result = run(args.src, Path(tmp))
    args.output.write_text(json.dumps(result, indent=1, sort_keys=True))
    print(f"{len(result)} data files digested -> {args.output}")
    if args.compare:
        before = json.loads(args.compare.read_text())
        changed = sorted(k for k in before.keys() & result.keys() if before[k] != result[k])
        missing = sorted(before.keys() - result.keys())
        new = sorted(result.keys() - before.keys())
        same = len(before.keys() & result.keys()) - len(changed)
        print(f"identical: {same}; changed: {len(changed)}; missing: {len(missing)}; new: {len(new)}")
        before_dir = args.compare.with_suffix("")  # before.json -> before/ (the --keep folder, by convention)
        worst = 0.0
        for n in changed:
            diff = None
            if args.keep and (before_dir / n).exists():
                diff = numeric_difference(before_dir / n, args.keep / n, before_dir.resolve(), args.keep)
            if diff is not None:
                worst = max(worst, diff)
            print(f"  changed: {n}" + ("" if diff is None else f" (numbers differ by at most {diff:.3g} x RMS)"))
        for label, names in (("missing", missing), ("new", new)):
            for n in names:
                print(f"  {label}: {n}")
        if changed:
            print(f"largest numeric difference among changed tables: {worst:.3g} x column RMS")
        return 1 if changed or missing else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
