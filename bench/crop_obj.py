#!/usr/bin/env python3
"""Cuts a small repro out of a large OBJ: every face of the materials not
named by --crop, and the faces of those that are whose vertices all lie in
an x-z box. Used to chase a mesher failure or an image error of a large
field on a few of its letters, with its own camera.

    python3 bench/crop_obj.py scenes/rfield.obj /tmp/rcrop.obj --crop letter \\
        --x 16,36 --z 28,38 --camera "eye 26 10 48 look_at 26 0.8 33 up 0 1 0 fov 30"
    cp scenes/rfield.mtl /tmp/    # the crop keeps the source's mtllib line

The 18 front letters this gives, meshed at rfield's own scale (`vkrad
/tmp/rcrop.obj --max-edge 3.32 --display-edge 1.66`), show rfield's letter
errors in a 4 s run.
"""
import argparse


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("source")
    ap.add_argument("out")
    ap.add_argument("--crop", action="append", default=[], help="a material whose faces are cropped (repeatable)")
    ap.add_argument("--x", default="-inf,inf", help="lo,hi")
    ap.add_argument("--z", default="-inf,inf", help="lo,hi")
    ap.add_argument("--camera", help="a `# vkrad camera` line for the crop (without the prefix)")
    a = ap.parse_args()
    (x0, x1), (z0, z1) = (tuple(map(float, s.split(","))) for s in (a.x, a.z))
    vertices, faces, material, mtllib = [], [], None, None
    for line in open(a.source):
        t = line.split()
        if not t:
            continue
        if t[0] == "v":
            vertices.append(tuple(map(float, t[1:4])))
        elif t[0] == "f":
            faces.append((material, [int(x.split("/")[0]) for x in t[1:]]))
        elif t[0] == "usemtl":
            material = t[1]
        elif t[0] == "mtllib":
            mtllib = line.strip()
    keep = []
    for m, f in faces:
        points = [vertices[i - 1 if i > 0 else len(vertices) + i] for i in f]
        if m not in a.crop or all(x0 <= p[0] <= x1 and z0 <= p[2] <= z1 for p in points):
            keep.append((m, f))
    new_id = {}
    for _, f in keep:
        for i in f:
            new_id.setdefault(i, len(new_id) + 1)
    with open(a.out, "w") as o:
        if a.camera:
            o.write(f"# vkrad camera {a.camera}\n")
        if mtllib:
            o.write(mtllib + "\n")
        for i in sorted(new_id, key=new_id.get):
            o.write("v %r %r %r\n" % vertices[i - 1 if i > 0 else len(vertices) + i])
        last = None
        for m, f in keep:
            if m != last:
                o.write(f"usemtl {m}\n")
                last = m
            o.write("f " + " ".join(str(new_id[i]) for i in f) + "\n")
    print(f"{a.out}: {len(keep)} of {len(faces)} faces")


if __name__ == "__main__":
    main()
