#!/usr/bin/env python3
"""Scores an image vkrad already wrote (.exr, linear radiance) against a
reference compare.py made (out/SCENE-ref.exr and its masks), with the same
error measures: relative RMSE and bias over the lit pixels (reference above
1% of its mean, emitters excluded), and over the interior mask.

    python3 score.py --scene rfield --size 256x256 image.exr [image2.exr ...]
"""
import argparse
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import compare  # noqa: E402  (sets up Mitsuba for the EXR reader)


def score(scene, image, size="256x256", out=os.path.join(HERE, "out")):
    """compare.errors of `image` against out/SCENE-ref.exr over the lit and
    interior masks; None when that reference or its masks are missing."""
    ref_path = os.path.join(out, f"{scene}-ref.exr")
    masks_path = os.path.join(out, f"{scene}-{size}-masks-v2.npz")
    if not (os.path.exists(ref_path) and os.path.exists(masks_path)):
        return None
    ref = compare.read_exr(ref_path)
    z = compare.np.load(masks_path)
    lum = ref.mean(axis=2)
    lit = (lum > 0.01 * lum.mean()) & ~z["sees_emitter"]
    masks = {"lit": lit, "interior": lit & z["interior"]}
    return compare.errors(compare.read_exr(image), ref, masks)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", required=True)
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("images", nargs="+")
    a = ap.parse_args()
    compare.set_variant("scalar_rgb")
    for path in a.images:
        errors = score(a.scene, path, a.size, a.out)
        if errors is None:
            sys.exit(f"no reference for {a.scene} at {a.size} in {a.out}: run compare.py first")
        print(json.dumps({"image": path, **errors}))


if __name__ == "__main__":
    main()
