#!/usr/bin/env python3
"""Write the STL geometry the shipped cases use into cases/geometry/.

The outputs are committed; CI never runs this script. Python 3 standard library only.
Run from anywhere: python3 scripts/make-geometry.py

All lengths are in millimetres (case files read them with `scale: 1.0e-3`).

  profiled_blade.stl  binary STL. A recoater blade: the x-z profile is a 2 mm wide (x from -1 to
                      +1) by 6 mm tall (z from 0 to 6) rectangle whose lower front corner (x = +1,
                      z = 0; the blade travels towards +x) is rounded with a 0.5 mm radius in 16
                      straight segments; the other corners are sharp. Extruded along y from -2 to
                      +2 and closed with two flat end caps. Normals point out of the solid. Origin
                      at the bottom centre of the blade.
  drum.stl            ASCII STL. A closed drum: a cylinder of radius 5 mm around the y axis, y from
                      -1 to +1, the mantle in 96 segments and two flat end disks fan-triangulated
                      from their centres. Normals point INTO the drum (towards the particles it
                      holds): the solid name says so.

The unit test tests/test_case_geometry.cpp reads both files back and checks the triangle counts,
the bounding boxes, that every edge is shared by exactly two triangles, and the enclosed volume
(its sign gives the winding).
"""

import math
import pathlib
import struct

BLADE_HALF_WIDTH = 1.0  # x from -1 to +1 [mm]
BLADE_HEIGHT = 6.0  # z from 0 to 6 [mm]
BLADE_EDGE_RADIUS = 0.5  # radius of the lower front edge [mm]
BLADE_EDGE_SEGMENTS = 16
BLADE_HALF_LENGTH = 2.0  # y from -2 to +2 [mm]

DRUM_RADIUS = 5.0  # inner radius [mm]
DRUM_HALF_LENGTH = 1.0  # y from -1 to +1 [mm]
DRUM_SEGMENTS = 96


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def unit_normal(tri):
    """Right-handed normal of the winding: (v1 - v0) x (v2 - v0), normalised."""
    n = cross(sub(tri[1], tri[0]), sub(tri[2], tri[0]))
    length = math.sqrt(dot(n, n))
    return (n[0] / length, n[1] / length, n[2] / length)


def signed_volume(triangles):
    """Volume enclosed by a closed surface (divergence theorem): positive for outward normals."""
    return sum(dot(a, cross(b, c)) for a, b, c in triangles) / 6.0


def clean(value):
    """Snap the round-off of cos(pi/2) and the like to zero, so the files hold exact zeros."""
    return 0.0 if abs(value) < 1e-12 else value


def blade_profile():
    """The blade's outline in the x-z plane, counter-clockwise (x right, z up), starting at the
    top back corner so that the end caps can be fanned from it (a convex outline: every fan
    triangle from one corner is proper)."""
    r = BLADE_EDGE_RADIUS
    centre_x, centre_z = BLADE_HALF_WIDTH - r, r
    outline = [(-BLADE_HALF_WIDTH, BLADE_HEIGHT), (-BLADE_HALF_WIDTH, 0.0)]
    for k in range(BLADE_EDGE_SEGMENTS + 1):
        # From the bottom (angle -90 degrees) to the front face (0 degrees); ends set exactly.
        if k == 0:
            outline.append((centre_x, 0.0))
        elif k == BLADE_EDGE_SEGMENTS:
            outline.append((BLADE_HALF_WIDTH, centre_z))
        else:
            angle = -0.5 * math.pi + 0.5 * math.pi * k / BLADE_EDGE_SEGMENTS
            outline.append((centre_x + r * math.cos(angle), centre_z + r * math.sin(angle)))
    outline.append((BLADE_HALF_WIDTH, BLADE_HEIGHT))
    return outline


def blade_triangles():
    outline = blade_profile()
    y0, y1 = -BLADE_HALF_LENGTH, BLADE_HALF_LENGTH
    n = len(outline)
    triangles = []
    # Mantle: for a counter-clockwise outline (A, C, B) and (A, D, C) face outwards.
    for i in range(n):
        (xa, za), (xb, zb) = outline[i], outline[(i + 1) % n]
        a, b = (xa, y0, za), (xb, y0, zb)
        c, d = (xb, y1, zb), (xa, y1, za)
        triangles += [(a, c, b), (a, d, c)]
    # End caps fanned from the first corner: outwards is -y at y0 and +y at y1.
    q0 = outline[0]
    for i in range(1, n - 1):
        qi, qj = outline[i], outline[i + 1]
        triangles.append(((q0[0], y0, q0[1]), (qi[0], y0, qi[1]), (qj[0], y0, qj[1])))
        triangles.append(((q0[0], y1, q0[1]), (qj[0], y1, qj[1]), (qi[0], y1, qi[1])))
    return triangles


def drum_triangles():
    y0, y1 = -DRUM_HALF_LENGTH, DRUM_HALF_LENGTH
    ring = []
    for k in range(DRUM_SEGMENTS):
        angle = 2.0 * math.pi * k / DRUM_SEGMENTS
        ring.append((clean(DRUM_RADIUS * math.cos(angle)), clean(DRUM_RADIUS * math.sin(angle))))
    triangles = []
    # The ring is counter-clockwise in x-z, so (A, B, C) and (A, C, D) face inwards.
    for k in range(DRUM_SEGMENTS):
        (xa, za), (xb, zb) = ring[k], ring[(k + 1) % DRUM_SEGMENTS]
        a, b = (xa, y0, za), (xb, y0, zb)
        c, d = (xb, y1, zb), (xa, y1, za)
        triangles += [(a, b, c), (a, c, d)]
    # End disks fanned from their centres: inwards is +y at y0 and -y at y1.
    for k in range(DRUM_SEGMENTS):
        (xa, za), (xb, zb) = ring[k], ring[(k + 1) % DRUM_SEGMENTS]
        triangles.append(((0.0, y0, 0.0), (xb, y0, zb), (xa, y0, za)))
        triangles.append(((0.0, y1, 0.0), (xa, y1, za), (xb, y1, zb)))
    return triangles


def write_binary_stl(path, header, triangles):
    data = bytearray(header.encode("ascii")[:80].ljust(80, b" "))
    data += struct.pack("<I", len(triangles))
    for tri in triangles:
        data += struct.pack("<3f", *unit_normal(tri))
        for vertex in tri:
            data += struct.pack("<3f", *vertex)
        data += struct.pack("<H", 0)
    path.write_bytes(bytes(data))


def write_ascii_stl(path, name, triangles):
    # 9 significant digits round-trip a float, which is what STL readers (VTK) store.
    def fmt(v):
        return " ".join("%.9g" % c for c in v)

    lines = ["solid " + name]
    for tri in triangles:
        lines.append("  facet normal " + fmt(unit_normal(tri)))
        lines.append("    outer loop")
        for vertex in tri:
            lines.append("      vertex " + fmt(vertex))
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid " + name)
    path.write_text("\n".join(lines) + "\n")


def main():
    out = pathlib.Path(__file__).resolve().parent.parent / "cases" / "geometry"
    out.mkdir(parents=True, exist_ok=True)

    blade = blade_triangles()
    blade_volume = signed_volume(blade)
    r = BLADE_EDGE_RADIUS
    # Rectangle minus the corner square plus the polygonal quarter disk (a fan of isosceles
    # triangles of apex angle (pi/2)/segments around the arc centre).
    blade_area = (2.0 * BLADE_HALF_WIDTH * BLADE_HEIGHT - r * r + BLADE_EDGE_SEGMENTS * 0.5 * r * r
                  * math.sin(0.5 * math.pi / BLADE_EDGE_SEGMENTS))
    expected = blade_area * 2.0 * BLADE_HALF_LENGTH
    assert abs(blade_volume - expected) < 1e-12 * expected, (blade_volume, expected)
    write_binary_stl(out / "profiled_blade.stl",
                     "bondem profiled recoater blade, mm, normals outward, "
                     "scripts/make-geometry.py", blade)

    drum = drum_triangles()
    drum_volume = signed_volume(drum)
    drum_area = 0.5 * DRUM_SEGMENTS * DRUM_RADIUS ** 2 * math.sin(2.0 * math.pi / DRUM_SEGMENTS)
    drum_expected = -drum_area * 2.0 * DRUM_HALF_LENGTH  # negative: normals point inwards
    assert abs(drum_volume - drum_expected) < 1e-12 * -drum_expected, (drum_volume, drum_expected)
    write_ascii_stl(out / "drum.stl", "drum_r5mm_l2mm_96seg_normals_inward", drum)

    for name, tris, volume in (("profiled_blade.stl", blade, blade_volume),
                               ("drum.stl", drum, drum_volume)):
        size = (out / name).stat().st_size
        print("%-20s %4d triangles, signed volume %.12g mm^3, %d bytes" % (name, len(tris), volume,
                                                                          size))


if __name__ == "__main__":
    main()
