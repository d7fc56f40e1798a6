"""Compares the column's silhouette in an engine frame and in a Blender render of the exported
frame (docs/EXPORT.md), run with Blender's Python (it reads PNGs and has numpy):

    blender -b --factory-startup -P tools/silhouette_iou.py -- \\
        ENGINE.png ENGINE_NO_ASH.png BLENDER_ASH.png [--out SIDE_BY_SIDE.png] [--min-iou 0.7]

The engine's ash mask is where the frame differs from the same frame rendered with
`--hide ash` by more than DIFF (of 255) in any channel; Blender's is where the `--only-ash`
render (transparent film) has an alpha above ALPHA. Prints both masks' areas and their
intersection over union; exits 1 if it is below --min-iou. --out writes the engine frame,
the Blender render and the two masks (engine red, Blender blue, both white) side by side.
"""

import argparse
import sys

import bpy
import numpy as np

DIFF = 6.0 / 255.0
ALPHA = 0.05


def load(path):
    img = bpy.data.images.load(path)
    w, h = img.size
    px = np.array(img.pixels[:], dtype=np.float32).reshape(h, w, 4)
    return px


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="silhouette_iou.py")
    p.add_argument("engine")
    p.add_argument("engine_no_ash")
    p.add_argument("blender")
    p.add_argument("--out")
    p.add_argument("--min-iou", type=float, default=0.7)
    a = p.parse_args(argv)
    full, bare, ours = load(a.engine), load(a.engine_no_ash), load(a.blender)
    if full.shape != bare.shape or full.shape != ours.shape:
        sys.exit(f"sizes differ: {full.shape} {bare.shape} {ours.shape}")
    engine = (np.abs(full[..., :3] - bare[..., :3]).max(axis=2) > DIFF)
    blender = ours[..., 3] > ALPHA
    inter = np.logical_and(engine, blender).sum()
    union = np.logical_or(engine, blender).sum()
    iou = inter / union if union else 0.0
    print(f"engine ash {engine.sum()} px, blender ash {blender.sum()} px, intersection {inter}, "
          f"union {union}, IoU {iou:.3f}")
    if a.out:
        h, w = engine.shape
        masks = np.zeros((h, w, 4), dtype=np.float32)
        masks[..., 3] = 1.0
        masks[..., 0] = engine
        masks[..., 2] = blender
        masks[..., 1] = np.logical_and(engine, blender)
        flat = ours.copy()
        # Blender's render over the engine's sky-free grey, so its transparent film reads.
        flat[..., :3] = flat[..., :3] * flat[..., 3:4] + 0.5 * (1.0 - flat[..., 3:4])
        flat[..., 3] = 1.0
        row = np.concatenate([full, flat, masks], axis=1)
        out = bpy.data.images.new("side_by_side", width=3 * w, height=h, alpha=True)
        out.pixels[:] = row.ravel()
        out.filepath_raw = a.out
        out.file_format = "PNG"
        out.save()
        print(f"wrote {a.out}")
    if iou < a.min_iou:
        print(f"IoU {iou:.3f} below {a.min_iou}")
        sys.exit(1)


main()
