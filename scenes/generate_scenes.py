#!/usr/bin/env python3
"""Generates the built-in scenes `r` (thesis fig. 17: an extruded letter R on
a floor, 138 polygons), `rfield` (175 of those letters: the thesis's
23,872-polygon scale test) and `vise` (thesis fig. 26: a bench vise on a
table, about 1000 polygons), and `curved.obj` (the Cornell box's room with a
finely tessellated sphere and torus, one triangle per face and no normals,
as a CAD or Blender export gives them). Python 3 standard library only; run
from anywhere:

    python3 scenes/generate_scenes.py
    python3 scenes/generate_scenes.py --scaling /tmp/vkrad-scaling   # letter fields, curved surfaces
    python3 scenes/generate_scenes.py --interiors /tmp/vkrad-interiors  # dining halls, 10k-200k faces
    python3 scenes/generate_scenes.py --offices /tmp/vkrad-offices  # one office, 1 to 400 luminaires
    python3 scenes/generate_scenes.py --textured /tmp/vkrad-textured  # the Cornell box, checkered floor

Every face is planar and convex, counter-clockwise seen from outside (its
front), with no degenerate faces.
"""

import math
import os
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


class Obj:
    def __init__(self, header, camera, mtllib):
        self.lines = ["# " + line if line else "#" for line in header.splitlines()]
        self.lines += ["#", "# vkrad camera " + camera, "", "mtllib " + mtllib]
        self.count = 0
        self.faces = 0

    def group(self, name, material):
        self.lines += ["", "o " + name, "usemtl " + material]

    def face(self, points):
        assert len(points) >= 3
        base = self.count
        for p in points:
            self.lines.append("v %s %s %s" % tuple(fmt(c) for c in p))
        self.count += len(points)
        self.lines.append("f " + " ".join(str(base + i + 1) for i in range(len(points))))
        self.faces += 1

    def write(self, path):
        with open(path, "w", newline="\n") as f:
            f.write("\n".join(self.lines) + "\n")


def fmt(x):
    s = "%.6f" % x
    s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def box(obj, lo, hi):
    """An axis-aligned box, six faces facing out."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    obj.face([(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)])  # bottom, -y
    obj.face([(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)])  # top, +y
    obj.face([(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)])  # -z
    obj.face([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)])  # +z
    obj.face([(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)])  # -x
    obj.face([(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)])  # +x


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def scale(a, s):
    return tuple(x * s for x in a)


def cylinder(obj, centre, axis, u, v, radius, t0, t1, sides, segments, caps=True):
    """A faceted cylinder along unit `axis` (u x v = axis) from t0 to t1:
    sides x segments quads, and triangle-fan caps."""

    def ring(i, t):
        a = 2.0 * math.pi * (i % sides) / sides
        off = add(scale(u, radius * math.cos(a)), scale(v, radius * math.sin(a)))
        return add(add(centre, scale(axis, t)), off)

    ts = [t0 + (t1 - t0) * j / segments for j in range(segments + 1)]
    for j in range(segments):
        for i in range(sides):
            obj.face([ring(i, ts[j]), ring(i + 1, ts[j]), ring(i + 1, ts[j + 1]), ring(i, ts[j + 1])])
    if caps:
        c0 = add(centre, scale(axis, t0))
        c1 = add(centre, scale(axis, t1))
        for i in range(sides):
            obj.face([c1, ring(i, t1), ring(i + 1, t1)])
            obj.face([c0, ring(i + 1, t0), ring(i, t0)])


def light(obj, cx, y, cz, half):
    """A square light at height y facing down."""
    obj.face([(cx - half, y, cz - half), (cx + half, y, cz - half),
              (cx + half, y, cz + half), (cx - half, y, cz + half)])


def r_pieces():
    """The letter R's convex pieces (x-y, counter-clockwise seen from +z)
    and its outline edges."""
    n_arc = 26
    thick = 0.6
    z_back, z_front = -thick / 2, thick / 2
    pieces = []  # convex pieces of the letter in x-y, counter-clockwise
    rect = lambda x0, y0, x1, y1: [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    for y0, y1 in [(0, 2), (2, 2.4), (2.4, 3.6), (3.6, 4)]:
        pieces.append(rect(0, y0, 0.8, y1))  # the stem, split where bars join
    pieces.append(rect(0.8, 3.6, 1.5, 4))  # top bar
    pieces.append(rect(0.8, 2, 1.0, 2.4))  # middle bar, two pieces so the
    pieces.append(rect(1.0, 2, 1.5, 2.4))  # leg's top edge matches one
    pieces.append([(1.0, 2), (2.2, 0), (2.8, 0), (1.5, 2)])  # the leg
    cx, cy, r_out, r_in = 1.5, 3.0, 1.0, 0.6
    for i in range(n_arc):  # the bowl: annulus pieces from the top, clockwise
        a0 = math.pi / 2 - math.pi * i / n_arc
        a1 = math.pi / 2 - math.pi * (i + 1) / n_arc
        p = lambda r, a: (cx + r * math.cos(a), cy + r * math.sin(a))
        pieces.append([p(r_in, a0), p(r_in, a1), p(r_out, a1), p(r_out, a0)][::-1])
    # Make every piece counter-clockwise (seen from +z).
    def ccw(poly):
        s = sum(poly[i][0] * poly[(i + 1) % len(poly)][1] - poly[(i + 1) % len(poly)][0] * poly[i][1]
                for i in range(len(poly)))
        return poly if s > 0 else poly[::-1]
    pieces = [ccw(p) for p in pieces]
    # Outline edges: directed piece edges whose reverse no piece has.
    key = lambda p: (round(p[0], 9), round(p[1], 9))
    directed = set()
    for poly in pieces:
        for i in range(len(poly)):
            directed.add((key(poly[i]), key(poly[(i + 1) % len(poly)])))
    outline = [(a, b) for poly in pieces for a, b in
               ((poly[i], poly[(i + 1) % len(poly)]) for i in range(len(poly)))
               if (key(b), key(a)) not in directed]
    return pieces, outline


def r_letter(obj, dx=0.0, dz=0.0):
    """The extruded letter R (0.6 thick) standing at (dx, 0, dz)."""
    pieces, outline = r_pieces()
    thick = 0.6
    z_back, z_front = dz - thick / 2, dz + thick / 2
    for poly in pieces:
        obj.face([(x + dx, y, z_front) for x, y in poly])
    for poly in pieces:
        obj.face([(x + dx, y, z_back) for x, y in reversed(poly)])
    for (ax, ay), (bx, by) in outline:
        obj.face([(ax + dx, ay, z_front), (ax + dx, ay, z_back), (bx + dx, by, z_back), (bx + dx, by, z_front)])


def letter_mtl(name):
    """The materials of the letter scenes: floor, letter, light."""
    with open(os.path.join(HERE, name), "w", newline="\n") as f:
        f.write("# Kd: diffuse reflectance (0..1). Ke: emitted radiance L_e (RGB).\n\n"
                "newmtl floor\nKd 0.7 0.7 0.7\n\n"
                "newmtl letter\nKd 0.75 0.2 0.15\n\n"
                "newmtl light\nKd 0 0 0\nKe 10 10 10\n")


def r_scene():
    obj = Obj(
        "The \"R\" scene (after fig. 17 of the thesis): an extruded letter R\n"
        "(4 high, 0.6 thick, built from convex pieces: front, back and side\n"
        "walls) standing on a 12 x 8 floor at y = 0, under one square light\n"
        "(1 x 1, Ke 10) at y = 7 facing down. Generated by generate_scenes.py.",
        "eye 1.4 4.5 10 look_at 1.4 1.2 0 up 0 1 0 fov 45",
        "r.mtl",
    )
    obj.group("floor", "floor")
    obj.face([(-4, 0, -4), (-4, 0, 4), (8, 0, 4), (8, 0, -4)])
    obj.group("letter", "letter")
    r_letter(obj)
    obj.group("light", "light")
    light(obj, -1.0, 7.0, 2.0, 0.5)
    obj.write(os.path.join(HERE, "r.obj"))
    letter_mtl("r.mtl")
    return obj.faces


def vise_scene():
    obj = Obj(
        "The vise scene (after fig. 26 of the thesis): a bench vise on a table\n"
        "top: base, fixed and moving jaws with jaw plates, slide rail, a\n"
        "faceted screw (32 sides), a handle bar (16 sides) with two knobs,\n"
        "four hexagonal bolts, under one square light (10 x 10, Ke 10) at\n"
        "y = 45 facing down. Units: cm. Generated by generate_scenes.py.",
        "eye 40 35 55 look_at 4 6 0 up 0 1 0 fov 40",
        "vise.mtl",
    )
    obj.group("table", "table")
    box(obj, (-30, -4, -20), (30, 0, 20))
    obj.group("vise", "steel")
    box(obj, (-12, 0, -10), (12, 3, 10))  # base
    box(obj, (-12, 3, -7), (-4, 14, 7))  # fixed jaw
    box(obj, (2, 3, -7), (10, 14, 7))  # moving jaw
    box(obj, (-4, 8, -7), (-3, 14, 7))  # jaw plates
    box(obj, (1, 8, -7), (2, 14, 7))
    box(obj, (-4, 3, -3), (18, 6, 3))  # slide rail
    X, Y, Z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    cylinder(obj, (0, 9, 0), X, Y, Z, 1.2, -8, 26, 32, 20)  # screw
    cylinder(obj, (24, 9, 0), Z, X, Y, 0.5, -12, 12, 16, 12)  # handle bar
    box(obj, (23, 8, 12), (25, 10, 14))  # knobs
    box(obj, (23, 8, -14), (25, 10, -12))
    for bx in (-10, 10):
        for bz in (-9, 9):
            # Hexagonal bolt heads: 6 sides and a hexagonal top.
            cylinder(obj, (bx, 3, bz), Y, Z, X, 0.8, 0, 1, 6, 1, caps=False)
            top = [(bx + 0.8 * math.sin(2 * math.pi * i / 6), 4, bz + 0.8 * math.cos(2 * math.pi * i / 6))
                   for i in range(6)]
            obj.face(top)
            obj.face([(x, 3, z) for x, _, z in reversed(top)])
    obj.group("light", "light")
    light(obj, -5.0, 45.0, 10.0, 5.0)
    obj.write(os.path.join(HERE, "vise.obj"))
    with open(os.path.join(HERE, "vise.mtl"), "w", newline="\n") as f:
        f.write("# Kd: diffuse reflectance (0..1). Ke: emitted radiance L_e (RGB).\n\n"
                "newmtl table\nKd 0.6 0.45 0.3\n\n"
                "newmtl steel\nKd 0.5 0.55 0.6\n\n"
                "newmtl light\nKd 0 0 0\nKe 10 10 10\n")
    return obj.faces


def rfield_scene(letters=175, columns=14, out_dir=HERE, name="rfield"):
    """The thesis's scale test (its parallel-performance "R" scene had
    23,872 polygons): 175 letters R (136 faces each) in rows on a floor
    under one light, 175 x 136 + 2 = 23,802 polygons. Larger fields for
    scaling tests go elsewhere (`--rfield`)."""
    rows = (letters + columns - 1) // columns
    dx, dz = 4.0, 3.0
    width, depth = columns * dx, rows * dz
    obj = Obj(
        "The \"R field\" scene: the thesis's scale test (its parallel-performance\n"
        "\"R\" scene had 23,872 polygons): %d extruded letters R (as in r.obj)\n"
        "in rows of %d on a %g x %g floor, under one 8 x 8 light (Ke 10) at\n"
        "y = 30 facing down. Generated by generate_scenes.py." % (letters, columns, width + 4, depth + 4),
        "eye %g 28 %g look_at %g 0 %g up 0 1 0 fov 50" % (width / 2, depth + 30, width / 2, depth / 2 - 2),
        name + ".mtl",
    )
    obj.group("floor", "floor")
    obj.face([(-2, 0, -2), (-2, 0, depth + 2), (width + 2, 0, depth + 2), (width + 2, 0, -2)])
    obj.group("letters", "letter")
    for k in range(letters):
        r_letter(obj, dx * (k % columns) + 0.6, dz * (k // columns) + 1.5)
    obj.group("light", "light")
    light(obj, width / 2, 30.0, depth / 2, 4.0)
    obj.write(os.path.join(out_dir, name + ".obj"))
    letter_mtl(os.path.join(out_dir, name + ".mtl"))
    return obj.faces


def tessellated(obj, point, rows, cols):
    """Triangles of a closed parametric surface point(i, j) (i in 0..rows,
    j in 0..cols, wrapping in j), counter-clockwise seen from outside;
    degenerate triangles (at a pole) are left out."""
    for i in range(rows):
        for j in range(cols):
            a, b = point(i, j), point(i + 1, j)
            c, d = point(i + 1, j + 1), point(i, j + 1)
            for tri in ([a, b, c], [a, c, d]):
                u = [tri[1][k] - tri[0][k] for k in range(3)]
                v = [tri[2][k] - tri[0][k] for k in range(3)]
                n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
                if math.sqrt(sum(x * x for x in n)) > 1e-6:
                    obj.face(tri)


def cornell_room(comment):
    """An Obj with the Cornell box's walls and light (from cornell.obj) and
    its camera, for scenes that put their own objects in that room."""
    with open(os.path.join(HERE, "cornell.obj")) as f:
        lines = f.read().splitlines()
    room = lines[lines.index("o floor"):lines.index("o short_block")]
    obj = Obj(comment, "eye 278 273 -800 look_at 278 273 0 up 0 1 0 fov 39.3077", "cornell.mtl")
    obj.lines += [""] + room
    obj.count = sum(1 for line in room if line.startswith("v "))
    obj.faces = sum(1 for line in room if line.startswith("f "))
    return obj


def add_sphere(obj, cx, cz, r, rows):
    """A sphere of radius r standing on the floor at (cx, cz), in `rows`
    rows of 2 * rows triangle pairs."""
    def sphere(i, j):
        t, p = math.pi * i / rows, 2 * math.pi * j / (2 * rows)
        return (cx + r * math.sin(t) * math.cos(p), r + r * math.cos(t), cz - r * math.sin(t) * math.sin(p))

    tessellated(obj, sphere, rows, 2 * rows)


def add_torus(obj, tx, tz, big, small, rows):
    """A torus (radii big and small) lying on the floor at (tx, tz), in
    `rows` rows of 2 * rows triangle pairs."""
    def torus(i, j):
        t, p = 2 * math.pi * i / rows, 2 * math.pi * j / (2 * rows)
        ring = big + small * math.cos(t)
        return (tx + ring * math.cos(p), small - small * math.sin(t), tz - ring * math.sin(p))

    tessellated(obj, torus, rows, 2 * rows)


def curved_scene():
    """The Cornell box's walls and light, a sphere (radius 100) standing on
    the floor and a torus (radii 75 and 30) lying on it."""
    obj = cornell_room("A finely tessellated sphere and torus in the Cornell box's room (light\n"
                       "and walls from cornell.obj): every triangle its own face, no vertex\n"
                       "normals, as exported meshes come. Generated by generate_scenes.py.")
    obj.group("sphere", "white")
    add_sphere(obj, 390.0, 330.0, 100.0, 32)
    obj.group("torus", "white")
    add_torus(obj, 170.0, 190.0, 75.0, 30.0, 24)
    obj.write(os.path.join(HERE, "curved.obj"))
    return obj.faces


def surfaces_scene(polygons, out_dir, name):
    """Curved surfaces at about `polygons` triangles: the Cornell box's room
    (walls and light from cornell.obj) with a terrain (a height field over
    the back half of the floor), a sphere standing on the floor and a torus
    lying on it, each tessellated finer as `polygons` grows (a quarter to
    the sphere, a quarter to the torus, half to the terrain)."""
    n = max(4, int(round(math.sqrt(polygons / 16.0))))
    obj = cornell_room("Tessellated curved surfaces for vkrad's scaling bench: a terrain, a\n"
                       "sphere and a torus (%d-row tessellations) in the Cornell box's room.\n"
                       "Generated by generate_scenes.py --scaling." % n)
    obj.group("terrain", "white")
    g = 2 * n
    x0, x1, z0, z1 = 20.0, 530.0, 300.0, 540.0

    def height(u, v):
        # Zero along the border (it meets the floor), hills inside.
        bump = 0.6 + 0.4 * math.sin(3 * math.pi * u) * math.cos(2 * math.pi * v)
        return 60.0 * math.sin(math.pi * u) * math.sin(math.pi * v) * bump

    def ground(i, j):
        u, v = i / g, j / g
        return (x0 + (x1 - x0) * u, height(u, v), z0 + (z1 - z0) * v)

    for i in range(g):
        for j in range(g):
            a, b, c, d = ground(i, j), ground(i, j + 1), ground(i + 1, j + 1), ground(i + 1, j)
            # Counter-clockwise seen from above (+y): the front faces up.
            obj.face([a, b, c])
            obj.face([a, c, d])
    obj.group("sphere", "white")
    add_sphere(obj, 390.0, 170.0, 90.0, n)
    obj.group("torus", "white")
    add_torus(obj, 160.0, 150.0, 70.0, 28.0, n)
    obj.write(os.path.join(out_dir, name + ".obj"))
    shutil.copyfile(os.path.join(HERE, "cornell.mtl"), os.path.join(out_dir, "cornell.mtl"))
    return obj.faces


def room(obj, width, depth, height):
    """A box room from the origin to (width, height, depth), every face
    seen from inside: groups floor, ceiling and walls of those materials."""
    obj.group("floor", "floor")
    obj.face([(0, 0, 0), (0, 0, depth), (width, 0, depth), (width, 0, 0)])
    obj.group("ceiling", "ceiling")
    obj.face([(0, height, 0), (width, height, 0), (width, height, depth), (0, height, depth)])
    obj.group("walls", "wall")
    obj.face([(0, 0, 0), (width, 0, 0), (width, height, 0), (0, height, 0)])
    obj.face([(0, 0, depth), (0, height, depth), (width, height, depth), (width, 0, depth)])
    obj.face([(0, 0, 0), (0, height, 0), (0, height, depth), (0, 0, depth)])
    obj.face([(width, 0, 0), (width, 0, depth), (width, height, depth), (width, height, 0)])


def interior_scene(polygons, luminaires, out_dir, name):
    """A dining hall of about `polygons` faces lit by `luminaires` small
    square lights just under the ceiling: the kind of interior people
    bring (many small boxes, many small lights), for the memory and
    scaling tests. Tables (a top on four legs) with four chairs each, four
    plates and a vase (faceted cylinders, the vase finer as `polygons`
    grows) stand in a grid of 3 m cells; the room (3 m high, walls facing
    in) grows with the number of tables."""
    per_table_base = 30 + 4 * 36 + 4 * 48  # table, chairs, plates
    tables = max(1, int(round(polygons / 1500.0)))
    vase_sides = 24
    vase_faces = max(3 * vase_sides, polygons // tables - per_table_base)
    vase_segments = max(1, (vase_faces - 2 * vase_sides) // vase_sides)
    cols = int(math.ceil(math.sqrt(tables)))
    rows = int(math.ceil(tables / cols))
    cell, height = 3.0, 3.0
    width, depth = cols * cell + 2.0, rows * cell + 2.0
    obj = Obj(
        "A dining hall for vkrad's memory tests: %d tables with four chairs, four\n"
        "plates and a vase each, in a %g x %g x %g m room lit by %d small square\n"
        "lights just under the ceiling. Generated by generate_scenes.py --interiors."
        % (tables, width, depth, height, luminaires),
        "eye %g 1.7 %g look_at %g 0.9 %g up 0 1 0 fov 60"
        % (0.3, depth - 0.3, width / 2, depth / 2),
        name + ".mtl",
    )
    room(obj, width, depth, height)
    up, ux, uz = (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0)
    for k in range(tables):
        cx = 1.0 + cell * (k % cols) + cell / 2
        cz = 1.0 + cell * (k // cols) + cell / 2
        obj.group("table%d" % k, "wood")
        box(obj, (cx - 0.8, 0.72, cz - 0.5), (cx + 0.8, 0.77, cz + 0.5))
        for sx in (-1, 1):
            for sz in (-1, 1):
                lx, lz = cx + sx * 0.72, cz + sz * 0.42
                box(obj, (lx - 0.03, 0.0, lz - 0.03), (lx + 0.03, 0.72, lz + 0.03))
        obj.group("chairs%d" % k, "fabric")
        for dx, dz, bx, bz in ((-0.45, -0.8, 0, -1), (0.45, -0.8, 0, -1), (-0.45, 0.8, 0, 1), (0.45, 0.8, 0, 1)):
            sx, sz = cx + dx, cz + dz
            box(obj, (sx - 0.22, 0.43, sz - 0.22), (sx + 0.22, 0.47, sz + 0.22))
            # The back on the side away from the table.
            if bz < 0:
                box(obj, (sx - 0.22, 0.47, sz - 0.22), (sx + 0.22, 0.95, sz - 0.18))
            else:
                box(obj, (sx - 0.22, 0.47, sz + 0.18), (sx + 0.22, 0.95, sz + 0.22))
            for ex in (-1, 1):
                for ez in (-1, 1):
                    lx, lz = sx + ex * 0.19, sz + ez * 0.19
                    box(obj, (lx - 0.02, 0.0, lz - 0.02), (lx + 0.02, 0.43, lz + 0.02))
        obj.group("plates%d" % k, "china")
        for px, pz in ((-0.45, -0.28), (0.45, -0.28), (-0.45, 0.28), (0.45, 0.28)):
            cylinder(obj, (cx + px, 0.77, cz + pz), up, ux, uz, 0.12, 0.0, 0.015, 16, 1)
        obj.group("vase%d" % k, "china")
        cylinder(obj, (cx, 0.77, cz), up, ux, uz, 0.07, 0.0, 0.3, vase_sides, vase_segments)
    # Luminaires in a grid, 2 cm under the ceiling, facing down; their
    # radiance keeps the hall's light per floor area about the same.
    obj.group("lights", "light")
    lcols = int(math.ceil(math.sqrt(luminaires * width / depth)))
    lrows = int(math.ceil(luminaires / lcols))
    for k in range(luminaires):
        lx = width * ((k % lcols) + 0.5) / lcols
        lz = depth * ((k // lcols) + 0.5) / lrows
        light(obj, lx, height - 0.02, lz, 0.15)
    obj.write(os.path.join(out_dir, name + ".obj"))
    radiance = 2.0 * width * depth / (luminaires * 0.09)
    with open(os.path.join(out_dir, name + ".mtl"), "w", newline="\n") as f:
        f.write("# Kd: diffuse reflectance (0..1). Ke: emitted radiance L_e (RGB).\n\n"
                "newmtl floor\nKd 0.45 0.35 0.25\n\n"
                "newmtl ceiling\nKd 0.8 0.8 0.8\n\n"
                "newmtl wall\nKd 0.7 0.68 0.6\n\n"
                "newmtl wood\nKd 0.4 0.25 0.12\n\n"
                "newmtl fabric\nKd 0.55 0.1 0.1\n\n"
                "newmtl china\nKd 0.85 0.85 0.85\n\n"
                "newmtl light\nKd 0 0 0\nKe %g %g %g\n" % (radiance, radiance * 0.95, radiance * 0.85))
    return obj.faces


# The interiors for the memory tests: (name, polygons, luminaires).
INTERIORS = [
    ("interior-10k-1", 10000, 1),
    ("interior-10k-16", 10000, 16),
    ("interior-50k-64", 50000, 64),
    ("interior-200k-400", 200000, 400),
]


def interior_scenes(folder):
    """The interiors of [`INTERIORS`], written to `folder`."""
    os.makedirs(folder, exist_ok=True)
    for name, polygons, luminaires in INTERIORS:
        print("%s: %d faces" % (name, interior_scene(polygons, luminaires, folder, name)))


# The luminaire counts of the many-lights bench: one office each.
OFFICE_LUMINAIRES = (1, 24, 100, 400)


def office_scene(luminaires, out_dir, name):
    """An open-plan office, 16 x 10 x 3 m, with 24 desks (a top on two
    panel legs), a chair block at each and low partitions between the
    rows, lit by `luminaires` square panels in a grid just under the
    ceiling. The room and its furniture are the same whatever the count,
    and the panels' total emitted power is too (each panel's area falls
    as 1/count, its radiance stays), so that the gather's cost can be
    charted against the number of lights alone."""
    width, depth, height = 16.0, 10.0, 3.0
    obj = Obj(
        "An open-plan office for vkrad's many-lights bench: 24 desks in a\n"
        "%g x %g x %g m room lit by %d ceiling panels of equal total power.\n"
        "Generated by generate_scenes.py --offices." % (width, depth, height, luminaires),
        "eye 0.5 1.6 9.5 look_at 9 0.8 3 up 0 1 0 fov 65",
        name + ".mtl",
    )
    room(obj, width, depth, height)
    for row in range(4):
        z = 1.8 + 2.2 * row
        for col in range(6):
            x = 1.6 + 2.4 * col
            obj.group("desk%d_%d" % (row, col), "desk")
            box(obj, (x - 0.8, 0.72, z - 0.4), (x + 0.8, 0.75, z + 0.4))
            for sx in (-1, 1):
                box(obj, (x + sx * 0.75 - 0.02, 0.0, z - 0.35), (x + sx * 0.75 + 0.02, 0.72, z + 0.35))
            obj.group("chair%d_%d" % (row, col), "fabric")
            box(obj, (x - 0.25, 0.0, z + 0.55), (x + 0.25, 0.45, z + 1.0))
        obj.group("partition%d" % row, "partition")
        box(obj, (0.6, 0.0, z - 0.45), (15.4, 1.3, z - 0.42))
    obj.group("lights", "light")
    lcols = max(1, int(round(math.sqrt(luminaires * width / depth))))
    lrows = int(math.ceil(luminaires / lcols))
    half = 0.6 / math.sqrt(luminaires)
    for k in range(luminaires):
        lx = width * ((k % lcols) + 0.5) / lcols
        lz = depth * ((k // lcols) + 0.5) / lrows
        light(obj, lx, height - 0.02, lz, half)
    obj.write(os.path.join(out_dir, name + ".obj"))
    radiance = 40.0
    with open(os.path.join(out_dir, name + ".mtl"), "w", newline="\n") as f:
        f.write("# Kd: diffuse reflectance (0..1). Ke: emitted radiance L_e (RGB).\n\n"
                "newmtl floor\nKd 0.35 0.35 0.38\n\n"
                "newmtl ceiling\nKd 0.85 0.85 0.85\n\n"
                "newmtl wall\nKd 0.75 0.72 0.65\n\n"
                "newmtl desk\nKd 0.6 0.45 0.3\n\n"
                "newmtl fabric\nKd 0.2 0.25 0.5\n\n"
                "newmtl partition\nKd 0.5 0.55 0.5\n\n"
                "newmtl light\nKd 0 0 0\nKe %g %g %g\n" % (radiance, radiance, radiance * 0.9))
    return obj.faces


def office_scenes(folder):
    """The offices of [`OFFICE_LUMINAIRES`], written to `folder`."""
    os.makedirs(folder, exist_ok=True)
    for n in OFFICE_LUMINAIRES:
        name = "office-%d" % n
        print("%s: %d faces" % (name, office_scene(n, folder, name)))


def scan_scene(out_dir, name="scan-33k", rows=116):
    """A stand-in for a scanned statue: a lumpy blob of `rows` rows of
    rows + 28 columns (33,120 triangles at the default) standing on the
    Cornell room's floor. Its radius is shaped by a few low harmonics (the form)
    and a per-vertex jitter of 0.4% (a scanner's noise), so its normals are
    irregular, as a scan's are, not those of a smooth tessellation."""
    cols = rows + 28
    obj = cornell_room("A generated stand-in for a scanned statue (%d triangles of a lumpy,\n"
                       "noisy blob) in the Cornell box's room. Generated by\n"
                       "generate_scenes.py --scan." % (2 * rows * cols - 2 * cols))
    obj.group("statue", "white")
    cx, cz, r = 278.0, 280.0, 120.0

    def jitter(i, j):
        # A fixed hash in [-1, 1): the same file on every run.
        h = (i * 73856093) ^ (j * 19349663)
        h = (h * 2654435761) & 0xFFFFFFFF
        return h / 2147483648.0 - 1.0

    def radius(t, p, i, j):
        form = 1.0 + 0.18 * math.sin(3 * t) * math.cos(2 * p) + 0.09 * math.sin(5 * p + 1.0) * math.sin(4 * t)
        return r * form * (1.0 + 0.004 * jitter(i, j % cols))

    def point(i, j):
        t, p = math.pi * i / rows, 2 * math.pi * j / cols
        rr = radius(t, p, i, j) if 0 < i < rows else r * (1.0 + 0.18 * math.sin(3 * t))
        return (cx + rr * math.sin(t) * math.cos(p), rr * math.cos(t), cz - rr * math.sin(t) * math.sin(p))

    points = {(i, j): point(i, j) for i in range(rows + 1) for j in range(cols)}
    lift = -min(y for _, y, _ in points.values())
    at = lambda i, j: (lambda q: (q[0], q[1] + lift, q[2]))(points[(i, j % cols)])  # noqa: E731
    for i in range(rows):
        for j in range(cols):
            a, b, c, d = at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)
            # Outward: from the top pole down, j turning counter-clockwise
            # seen from above.
            if i > 0:
                obj.face([a, c, b])
            if i < rows - 1:
                obj.face([a, d, c])
    obj.write(os.path.join(out_dir, name + ".obj"))
    shutil.copyfile(os.path.join(HERE, "cornell.mtl"), os.path.join(out_dir, "cornell.mtl"))
    return obj.faces


def write_png(path, width, height, colour):
    """An 8-bit RGB PNG whose pixel (x, y), y from the top, is
    `colour(x, y)` (standard library only: zlib and struct)."""
    import struct
    import zlib

    rows = b"".join(
        b"\x00" + bytes(c for x in range(width) for c in colour(x, y)) for y in range(height)
    )

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header))
        f.write(chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def textured_box_scene(out_dir, name="cornell-checker"):
    """The Cornell box with a checkered floor (`map_Kd`, 8 x 8 squares),
    for the textured lightmap: written to `out_dir` with its MTL and PNG."""
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(HERE, "cornell.obj")) as f:
        obj = f.read()
    floor = "o floor\nusemtl white\n"
    assert obj.count(floor) == 1 and obj.count("mtllib cornell.mtl") == 1
    head, tail = obj.split(floor)
    face = "f 1 2 3 4\n"
    assert tail.count(face) >= 1
    tail = tail.replace(face, "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n", 1)
    obj = head.replace("mtllib cornell.mtl", "mtllib %s.mtl" % name) + "o floor\nusemtl checker\n" + tail
    with open(os.path.join(out_dir, name + ".obj"), "w", newline="\n") as f:
        f.write(obj)
    with open(os.path.join(HERE, "cornell.mtl")) as f:
        mtl = f.read()
    mtl += "\nnewmtl checker\nKd 0.8 0.8 0.8\nmap_Kd %s.png\n" % name
    with open(os.path.join(out_dir, name + ".mtl"), "w", newline="\n") as f:
        f.write(mtl)
    light, dark = (230, 220, 200), (60, 70, 110)
    write_png(os.path.join(out_dir, name + ".png"), 128, 128,
              lambda x, y: light if (x // 16 + y // 16) % 2 else dark)
    return obj.count("\nf ")


def scaling_scenes(folder):
    """Fields of letters R from 1 to 1,500 letters (138 to 204,002
    polygons) and curved surfaces from about 2,000 to 200,000 triangles
    (`surfaces-N`), for the scaling benches; written to `folder`, not into
    the crate."""
    os.makedirs(folder, exist_ok=True)
    for letters in (1, 12, 50, 175, 700, 1500):
        columns = max(1, int(round(math.sqrt(letters * 0.75))))
        name = "rfield-%d" % letters
        print("%s: %d faces" % (name, rfield_scene(letters, columns, folder, name)))
    for polygons in (2000, 8000, 32000, 100000, 200000):
        name = "surfaces-%dk" % (polygons // 1000)
        print("%s: %d faces" % (name, surfaces_scene(polygons, folder, name)))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--scaling":
        scaling_scenes(sys.argv[2])
        sys.exit(0)
    if len(sys.argv) == 3 and sys.argv[1] == "--interiors":
        interior_scenes(sys.argv[2])
        sys.exit(0)
    if len(sys.argv) == 3 and sys.argv[1] == "--offices":
        office_scenes(sys.argv[2])
        sys.exit(0)
    if len(sys.argv) == 3 and sys.argv[1] == "--textured":
        print("cornell-checker: %d faces" % textured_box_scene(sys.argv[2]))
        sys.exit(0)
    if len(sys.argv) == 3 and sys.argv[1] == "--scan":
        print("scan-33k: %d faces" % scan_scene(sys.argv[2]))
        sys.exit(0)
    if sys.argv[1:2] == ["--rfield"]:
        # A larger R field for scaling: --rfield LETTERS COLUMNS OUT_DIR
        # (e.g. 700 28 /tmp: 95,202 polygons in /tmp/rfield700.obj).
        letters, columns, out = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
        faces = rfield_scene(letters, columns, out, "rfield%d" % letters)
        print("rfield%d: %d faces" % (letters, faces))
        sys.exit(0)
    print("curved: %d faces" % curved_scene())
    print("r: %d faces" % r_scene())
    print("rfield: %d faces" % rfield_scene())
    print("vise: %d faces" % vise_scene())
