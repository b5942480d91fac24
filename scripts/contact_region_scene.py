"""Writes a scene whose model inputs are the free skin vertices a set of rigid walls can touch:
for each wall direction d (unit, from the body toward the wall), every free vertex x of the
`skin` surface with d . x >= max_free(d . y) - depth - margin, the band a wall pressed `depth`
into the undeformed body reaches, widened by `margin` for the deformation's spread. A wall
turning about z is sampled every degree over its angles. The inputs are listed one vertex each
(`within` spheres of 0.5 mm about the vertex), so the scene says exactly which they are.

    /usr/bin/python3 scripts/contact_region_scene.py BASE_SCENE OUT_SCENE --name NAME
        --depth 0.01 --margin 0.003 --wall 0 0 1 --turning-wall 0 1 0 -25 25
        [--surfaces skin base] [--comment TEXT]

BASE_SCENE gives the body (mesh, material, damping, integrator, step); only its name, comment
and model inputs change. The mesh is gmsh 2.2 ASCII with the physical surfaces --surfaces names
(default `skin`) and the fixed ones the scene names. Units: m, degrees."""
import argparse
import json
import math
import os
import sys


def read_msh(path):
    """Node coordinates by tag, and each physical surface's node tags by name."""
    with open(path) as fh:
        lines = fh.read().splitlines()
    i = 0
    names, nodes, surfaces = {}, {}, {}
    while i < len(lines):
        line = lines[i].strip()
        if line == "$MeshFormat" and lines[i + 1].split()[:2] != ["2.2", "0"]:
            sys.exit(f"{path}: gmsh 2.2 ASCII expected")
        if line == "$PhysicalNames":
            for k in range(int(lines[i + 1])):
                dim, tag, name = lines[i + 2 + k].split(maxsplit=2)
                names[(int(dim), int(tag))] = name.strip('"')
        elif line == "$Nodes":
            n = int(lines[i + 1])
            for k in range(n):
                f = lines[i + 2 + k].split()
                nodes[int(f[0])] = tuple(float(v) for v in f[1:4])
        elif line == "$Elements":
            n = int(lines[i + 1])
            for k in range(n):
                f = [int(v) for v in lines[i + 2 + k].split()]
                kind, n_tags = f[1], f[2]
                if kind != 2 or n_tags < 1:  # 3-node triangles with a physical tag: the surfaces
                    continue
                name = names.get((2, f[3]))
                if name:
                    surfaces.setdefault(name, set()).update(f[3 + n_tags:])
        i += 1
    return nodes, surfaces


def turned(d, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return (c * d[0] - s * d[1], s * d[0] + c * d[1], d[2])


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("base")
    p.add_argument("out")
    p.add_argument("--name", required=True)
    p.add_argument("--depth", type=float, required=True, help="m, the deepest press")
    p.add_argument("--margin", type=float, default=0.003, help="m")
    p.add_argument("--wall", type=float, nargs=3, action="append", default=[], metavar=("X", "Y", "Z"))
    p.add_argument("--turning-wall", type=float, nargs=5, action="append", default=[],
                   metavar=("X", "Y", "Z", "FROM_DEG", "TO_DEG"), help="turning about z")
    p.add_argument("--surfaces", nargs="+", default=["skin"],
                   help="the physical surfaces the walls may touch (a free body's 'base' too)")
    p.add_argument("--comment", default="")
    a = p.parse_args()
    if os.path.exists(a.out):
        sys.exit(f"{a.out} exists: not overwritten")
    with open(a.base) as fh:
        scene = json.load(fh)
    mesh = os.path.join(os.path.dirname(a.base), scene["mesh"]["file"])
    nodes, surfaces = read_msh(mesh)
    touched = set()
    for name in a.surfaces:
        if name not in surfaces:
            sys.exit(f"{mesh}: no physical surface '{name}'")
        touched |= surfaces[name]
    fixed = set()
    for s in scene.get("fixed_surfaces", []):
        fixed |= surfaces.get(s, set())
    free = sorted(touched - fixed)
    directions = [tuple(w) for w in a.wall]
    for x, y, z, lo, hi in a.turning_wall:
        steps = max(1, int(round(abs(hi - lo))))
        directions += [turned((x, y, z), lo + (hi - lo) * k / steps) for k in range(steps + 1)]
    if not directions:
        sys.exit("give at least one --wall or --turning-wall")
    chosen = set()
    for d in directions:
        n = math.sqrt(sum(c * c for c in d))
        if not n > 0:
            sys.exit("a wall direction must not be zero")
        d = tuple(c / n for c in d)
        h = {t: sum(c * x for c, x in zip(d, nodes[t])) for t in free}
        top = max(h.values())
        chosen |= {t for t in free if h[t] >= top - a.depth - a.margin}
    scene["name"] = a.name
    scene["comment"] = (a.comment + " " if a.comment else "") + (
        f"Model inputs: the {len(chosen)} free {' and '.join(a.surfaces)} vertices within {a.depth * 1e3:g} + "
        f"{a.margin * 1e3:g} mm of the outermost free point along each wall direction "
        f"(scripts/contact_region_scene.py).")
    # The mesh path is relative to the scene file; the output may live elsewhere.
    scene["mesh"]["file"] = os.path.relpath(mesh, os.path.dirname(os.path.abspath(a.out)))
    scene.setdefault("model", {})["inputs"] = {
        "surfaces": a.surfaces,
        "within": [{"center_m": list(nodes[t]), "radius_m": 0.0005} for t in sorted(chosen)]}
    with open(a.out + ".part", "w") as fh:
        json.dump(scene, fh, indent=1)
        fh.write("\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(a.out + ".part", a.out)
    print(f"{a.out}: {len(chosen)} input vertices")


if __name__ == "__main__":
    main()
