#!/usr/bin/env python3
"""Phantom obstacles: a ROS map_server grid (`skimap grid -o F.yaml`) against a skimap-sim
scene's true geometry (scene_geometry.json).

An occupied cell is explained when an axis-aligned box of the scene (walls, furniture; not
the floor or ceiling) that reaches into the band [band_min, band_max] lies within `slack`
of the cell, or an object or distractor's origin lies within 0.25 m; otherwise it is a
phantom obstacle. Prints the grid's counts, the phantoms, and how many true box cells
inside the room are occupied.

  python3 bench/grid_vs_floor_plan.py GRID.yaml DATASET/test/000001/scene_geometry.json
"""
import argparse
import json
import os


def read_pgm(path):
    with open(path, "rb") as f:
        data = f.read()
    parts, pos = [], 0
    while len(parts) < 4:  # magic, width, height, maxval; '#' comments between
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        start = pos
        while not data[pos:pos + 1].isspace():
            pos += 1
        parts.append(data[start:pos])
    pos += 1
    if parts[0] != b"P5":
        raise SystemExit(f"{path}: not a binary PGM")
    w, h = int(parts[1]), int(parts[2])
    return w, h, data[pos:pos + w * h]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("grid_yaml")
    ap.add_argument("geometry")
    ap.add_argument("--band_min", type=float, default=0.05)
    ap.add_argument("--band_max", type=float, default=1.5)
    ap.add_argument("--slack", type=float, default=0.05)
    a = ap.parse_args()
    meta = {}
    for line in open(a.grid_yaml):
        if ":" in line:
            k, v = line.split(":", 1)
            meta[k.strip()] = v.strip()
    res = float(meta["resolution"])
    origin = [float(x) for x in meta["origin"].strip("[]").split(",")[:2]]
    w, h, pixels = read_pgm(os.path.join(os.path.dirname(a.grid_yaml), meta["image"]))
    g = json.load(open(a.geometry))
    boxes = []
    for b in g["boxes"]:
        if b["kind"] in ("floor", "ceiling"):
            continue
        c, s = b["center"], b["size"]
        if c[2] + s[2] / 2 < a.band_min or c[2] - s[2] / 2 > a.band_max:
            continue
        boxes.append((c[0] - s[0] / 2, c[1] - s[1] / 2, c[0] + s[0] / 2, c[1] + s[1] / 2))
    things = [o["t_wm"][:2] for o in g.get("objects", []) + g.get("distractors", [])]
    room = g["room"]
    counts = {"occupied": 0, "free": 0, "unknown": 0}
    phantom = truth = truth_occupied = truth_free = 0
    for row in range(h):
        y = origin[1] + (h - 1 - row + 0.5) * res  # PGM row 0 is the top (largest y)
        for i in range(w):
            x = origin[0] + (i + 0.5) * res
            p = pixels[row * w + i]
            kind = "occupied" if p == 0 else "free" if p == 254 else "unknown"
            counts[kind] += 1
            inside = room["min"][0] < x < room["max"][0] and room["min"][1] < y < room["max"][1]
            in_box = any(b[0] <= x <= b[2] and b[1] <= y <= b[3] for b in boxes)
            if in_box and inside:
                truth += 1
                truth_occupied += kind == "occupied"
                truth_free += kind == "free"
            if kind != "occupied":
                continue
            sl = a.slack
            near = any(b[0] - sl <= x <= b[2] + sl and b[1] - sl <= y <= b[3] + sl for b in boxes)
            near = near or any((x - t[0]) ** 2 + (y - t[1]) ** 2 <= 0.25 ** 2 for t in things)
            phantom += not near
    print(f"cells {w}x{h} at {res} m: occupied {counts['occupied']}, free {counts['free']}, "
          f"unknown {counts['unknown']}")
    print(f"phantom obstacles (occupied, nothing of the scene within {a.slack} m): {phantom} "
          f"({phantom / max(1, counts['occupied']):.3f} of occupied)")
    print(f"true box cells in the room: {truth}, occupied {truth_occupied}, free {truth_free}")


if __name__ == "__main__":
    main()
