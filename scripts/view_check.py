#!/usr/bin/env python3
"""View consistency of recognised instances against a BOP dataset's depth images (an
offline analysis for docs/recognition.md, "View consistency"; not part of the server).

For each instance of `skimap eval --instances_dir` (optionally joined with the verdicts of
`--summary`), points sampled on the object's model surface (models/obj_XXXXXX.ply, by area)
are placed at the instance's pose and projected into every n-th frame of its test scene:
a point within --tolerance_mm of the observed depth agrees; a point more than that in front
of the observed depth is a violation (the camera saw through where the object would be);
a point behind it is occluded and says nothing. V = violations / (agreements + violations)
over the scene. A true pose has V near 0; a pose floating in free space, or sunk into
another object with its rest sticking out, has a large V.

  scripts/view_check.py DATASET INSTANCES_DIR [--summary FILE] [--every 10] [--points 600]
      [--tolerance_mm 15] [--min_score 0] [--json OUT]

Prints one line per instance (verdict when --summary is given, V, score, fit, scene, obj_id,
agreeing and violating points); --json writes the same as a list of objects. Needs Debian's
python3-numpy and python3-pil.
"""
import argparse
import json
import os
import sys

import numpy as np
from PIL import Image


def read_ply_surface(path, count, rng):
    """`count` points on the faces of an ASCII PLY mesh, uniform by area (model units)."""
    with open(path) as f:
        lines = f.read().split("\n")
    if not lines or lines[0].strip() != "ply":
        raise ValueError(f"{path}: not a PLY file")
    nv = nf = None
    header_end = None
    for i, line in enumerate(lines):
        if line.startswith("element vertex"):
            nv = int(line.split()[-1])
        elif line.startswith("element face"):
            nf = int(line.split()[-1])
        elif line.strip() == "end_header":
            header_end = i + 1
            break
    if nv is None or nf is None or header_end is None or nf == 0:
        raise ValueError(f"{path}: needs vertex and face elements (ASCII)")
    vertices = np.array([[float(x) for x in l.split()[:3]]
                         for l in lines[header_end:header_end + nv]])
    faces = np.array([[int(x) for x in l.split()[1:4]]
                      for l in lines[header_end + nv:header_end + nv + nf]])
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    pick = rng.choice(len(faces), count, p=area / area.sum())
    u, v = rng.random(count), rng.random(count)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    return a[pick] + u[:, None] * (b[pick] - a[pick]) + v[:, None] * (c[pick] - a[pick])


def count_view(points_world, frames, tolerance):
    """(agreeing, violating) points over `frames`: (K, R_w2c, t_w2c, depth in model units)."""
    agree = violate = 0
    for K, R, t, depth in frames:
        q = points_world @ R.T + t
        front = q[:, 2] > 1e-6
        if not front.any():
            continue
        uv = q[front] @ K.T
        u = np.round(uv[:, 0] / uv[:, 2]).astype(int)
        v = np.round(uv[:, 1] / uv[:, 2]).astype(int)
        inside = (u >= 0) & (u < depth.shape[1]) & (v >= 0) & (v < depth.shape[0])
        observed = depth[v[inside], u[inside]]
        predicted = q[front][inside, 2]
        valid = observed > 0
        agree += int((np.abs(predicted[valid] - observed[valid]) <= tolerance).sum())
        violate += int((predicted[valid] < observed[valid] - tolerance).sum())
    return agree, violate


def load_frames(scene_dir, every):
    with open(os.path.join(scene_dir, "scene_camera.json")) as f:
        cameras = json.load(f)
    frames = []
    for key in sorted(cameras, key=int)[::every]:
        c = cameras[key]
        if "cam_R_w2c" not in c:
            raise ValueError(f"{scene_dir}: frame {key} has no camera pose (cam_R_w2c)")
        depth = np.asarray(Image.open(os.path.join(scene_dir, "depth", f"{int(key):06d}.png")),
                           dtype=np.float64) * c.get("depth_scale", 1.0)
        frames.append((np.array(c["cam_K"]).reshape(3, 3), np.array(c["cam_R_w2c"]).reshape(3, 3),
                       np.array(c["cam_t_w2c"]), depth))
    return frames


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("dataset")
    p.add_argument("instances_dir")
    p.add_argument("--summary")
    p.add_argument("--every", type=int, default=10)
    p.add_argument("--points", type=int, default=600)
    p.add_argument("--tolerance_mm", type=float, default=15)
    p.add_argument("--min_score", type=float, default=0)
    p.add_argument("--json")
    a = p.parse_args(argv)
    if a.every < 1 or a.points < 1 or a.tolerance_mm <= 0:
        p.error("--every and --points must be >= 1, --tolerance_mm > 0")
    verdicts = {}
    if a.summary:
        with open(a.summary) as f:
            for d in json.load(f)["multi_view"]["detections"]:
                verdicts.setdefault((d["scene"], d["obj_id"], d["score"], round(d["fit"], 4)),
                                    d["true_positive"])
    rng = np.random.default_rng(1)
    models, rows = {}, []
    for name in sorted(os.listdir(a.instances_dir)):
        if not name.endswith(".json") or name.endswith(".single_view.json"):
            continue
        scene = name[:-len(".json")]
        scene_dir = os.path.join(a.dataset, "test", scene)
        if not os.path.isdir(scene_dir):
            p.error(f"{scene_dir}: no such test scene for {name}")
        frames = load_frames(scene_dir, a.every)
        with open(os.path.join(a.instances_dir, name)) as f:
            instances = json.load(f)
        for i in instances:
            if i["score"] < a.min_score:
                continue
            o = i["obj_id"]
            if o not in models:
                models[o] = read_ply_surface(
                    os.path.join(a.dataset, "models", f"obj_{o:06d}.ply"), a.points, rng)
            world = models[o] @ np.array(i["R"]).reshape(3, 3).T + np.array(i["t"])
            agree, violate = count_view(world, frames, a.tolerance_mm)
            rows.append({"scene": scene, "obj_id": o, "id": i.get("id"), "score": i["score"],
                         "fit": i.get("fit"), "agree": agree, "violate": violate,
                         "v": violate / (agree + violate) if agree + violate else None,
                         "true_positive": verdicts.get((scene, o, i["score"],
                                                        round(i.get("fit", 0), 4)))})
    for r in rows:
        verdict = {True: "TP", False: "FP", None: "--"}[r["true_positive"]]
        v = "V=%.2f" % r["v"] if r["v"] is not None else "V=nan"
        print(verdict, v, "score", r["score"], "fit", r["fit"], r["scene"], "obj", r["obj_id"],
              "agree", r["agree"], "violate", r["violate"])
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
