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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", required=True)
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("images", nargs="+")
    a = ap.parse_args()
    compare.set_variant("scalar_rgb")
    ref = compare.read_exr(os.path.join(a.out, f"{a.scene}-ref.exr"))
    z = compare.np.load(os.path.join(a.out, f"{a.scene}-{a.size}-masks-v2.npz"))
    lum = ref.mean(axis=2)
    lit = (lum > 0.01 * lum.mean()) & ~z["sees_emitter"]
    masks = {"lit": lit, "interior": lit & z["interior"]}
    for path in a.images:
        x = compare.read_exr(path)
        print(json.dumps({"image": path, **compare.errors(x, ref, masks)}))


if __name__ == "__main__":
    main()
