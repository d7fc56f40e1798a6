#!/usr/bin/python3
"""Checks an OpenVDB file written by volcano against what the exporter meant to write, with
OpenVDB itself (Debian's python3-openvdb):

    /usr/bin/python3 tools/check_vdb.py FRAME.vdb EXPECTED.json

EXPECTED.json (written by the exporter's tests, or `volcano export --expect`) lists per grid:
name, class, voxel_size, translation (world position of voxel (0,0,0)'s centre),
active_voxels, bbox ([[i,j,k], [i,j,k]], inclusive), sum (of the active values) and samples
([[i, j, k, value], ...]). Every grid of the file must be expected and every expected grid
present; values match to a relative error of 1e-6. Prints one line per grid; exits 1 on the
first mismatch with what differed."""

import json
import sys

import pyopenvdb as vdb


def close(a, b, rel=1e-6):
    return abs(a - b) <= rel * max(abs(a), abs(b), 1e-30)


def check(path, expected):
    grids, _file_meta = vdb.readAll(path)
    by_name = {g.name: g for g in grids}
    want = {g["name"]: g for g in expected["grids"]}
    if set(by_name) != set(want):
        return f"grids {sorted(by_name)} in the file, {sorted(want)} expected"
    for name, w in want.items():
        g = by_name[name]
        t = g.transform
        problems = []
        if g.valueTypeName != "float":
            problems.append(f"value type {g.valueTypeName}")
        if g.gridClass != w["class"]:
            problems.append(f"class {g.gridClass!r}, expected {w['class']!r}")
        if not close(t.voxelSize()[0], w["voxel_size"], 1e-12) or len(set(t.voxelSize())) != 1:
            problems.append(f"voxel size {t.voxelSize()}, expected {w['voxel_size']}")
        origin = t.indexToWorld((0, 0, 0))
        if any(abs(a - b) > 1e-9 * max(1.0, abs(b)) for a, b in zip(origin, w["translation"])):
            problems.append(f"voxel (0,0,0) at {origin}, expected {w['translation']}")
        if g.activeVoxelCount() != w["active_voxels"]:
            problems.append(f"{g.activeVoxelCount()} active voxels, expected {w['active_voxels']}")
        if w["active_voxels"]:
            lo, hi = g.evalActiveVoxelBoundingBox()
            if [list(lo), list(hi)] != w["bbox"]:
                problems.append(f"active box {lo}..{hi}, expected {w['bbox']}")
        total = sum(it.value for it in g.citerOnValues())
        if not close(total, w["sum"], 1e-5):
            problems.append(f"sum of active values {total}, expected {w['sum']}")
        acc = g.getConstAccessor()
        for i, j, k, value in w["samples"]:
            got = acc.getValue((i, j, k))
            if not close(got, value) or acc.isValueOn((i, j, k)) != (value != 0.0):
                problems.append(f"voxel ({i},{j},{k}) = {got} (on: {acc.isValueOn((i, j, k))}), expected {value}")
                break
        for key, value in w.get("metadata", {}).items():
            if key not in g.metadata or g.metadata[key] != value:
                problems.append(f"metadata {key} = {g.metadata.get(key)!r}, expected {value!r}")
        if problems:
            return f"grid {name}: " + "; ".join(problems)
        print(f"ok {name}: {g.gridClass}, voxel {t.voxelSize()[0]} m, {g.activeVoxelCount()} active voxels, "
              f"{len(w['samples'])} samples, sum {total:.6g}")
    return None


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[2]) as f:
        expected = json.load(f)
    error = check(sys.argv[1], expected)
    if error:
        print(f"MISMATCH {sys.argv[1]}: {error}")
        sys.exit(1)
