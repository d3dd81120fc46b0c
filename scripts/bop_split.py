#!/usr/bin/env python3
"""Splits one annotated BOP scene into a train split (per-object sequences) and a test
scene, so `skimap eval DIR --train` trains from the masked object pixels of some frames and
recognises the objects in the others (issue 11's real-data run on ../shared/data/ycbv-0000).

Usage: scripts/bop_split.py SRC_ROOT --scene test/000000 --train_frames 0,2,4,6,8 --out DIR

DIR gets SRC_ROOT's camera.json, objects.json and models/ (when present) and
  train/<obj_id:06d>/  the --train_frames that annotate the object with a visible mask,
  test/<scene>/        every other frame of the scene.
Both hold filtered scene_camera.json, scene_gt.json and scene_gt_info.json; their rgb/,
depth/ and mask_visib/ are symbolic links to the source's (frames come from
scene_camera.json, so the extra images are never read). The source is not modified.
"""
import argparse
import json
import os
import shutil
import sys


def load(path):
    with open(path) as f:
        return json.load(f)


def write_scene(src_scene, dst_scene, frames):
    os.makedirs(dst_scene, exist_ok=True)
    for name in ("scene_camera.json", "scene_gt.json", "scene_gt_info.json"):
        path = os.path.join(src_scene, name)
        if not os.path.exists(path):
            continue
        data = load(path)
        with open(os.path.join(dst_scene, name), "w") as f:
            json.dump({k: data[k] for k in frames if k in data}, f, indent=1)
    for sub in ("rgb", "depth", "mask_visib"):
        src = os.path.abspath(os.path.join(src_scene, sub))
        dst = os.path.join(dst_scene, sub)
        if os.path.isdir(src) and not os.path.lexists(dst):
            os.symlink(src, dst)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("src")
    p.add_argument("--scene", required=True, help="the scene folder under SRC, e.g. test/000000")
    p.add_argument("--train_frames", required=True, help="image ids for training, e.g. 0,2,4")
    p.add_argument("--out", required=True)
    args = p.parse_args()

    src_scene = os.path.join(args.src, args.scene)
    if not os.path.exists(os.path.join(src_scene, "scene_camera.json")):
        p.error(f"--scene: {src_scene} has no scene_camera.json")
    if not os.path.exists(os.path.join(src_scene, "scene_gt.json")):
        p.error(f"--scene: {src_scene} has no scene_gt.json (no objects to train)")
    cameras = load(os.path.join(src_scene, "scene_camera.json"))
    gt = load(os.path.join(src_scene, "scene_gt.json"))
    try:
        train = {str(int(v)) for v in args.train_frames.split(",") if v.strip()}
    except ValueError:
        p.error("--train_frames must be comma-separated image ids")
    unknown = sorted(train - set(cameras), key=int)
    if unknown:
        p.error(f"--train_frames: image ids {','.join(unknown)} are not in the scene")
    test = sorted(set(cameras) - train, key=int)
    if not train or not test:
        p.error("--train_frames must leave at least one frame on each side")

    os.makedirs(args.out, exist_ok=True)
    for name in ("camera.json", "objects.json", "dataset_info.json"):
        if os.path.exists(os.path.join(args.src, name)):
            shutil.copyfile(os.path.join(args.src, name), os.path.join(args.out, name))
    models = os.path.abspath(os.path.join(args.src, "models"))
    if os.path.isdir(models) and not os.path.lexists(os.path.join(args.out, "models")):
        os.symlink(models, os.path.join(args.out, "models"))

    mask_dir = os.path.join(src_scene, "mask_visib")
    per_object = {}
    for image in sorted(train, key=int):
        for k, entry in enumerate(gt.get(image, [])):
            mask = os.path.join(mask_dir, f"{int(image):06d}_{k:06d}.png")
            if os.path.exists(mask):
                per_object.setdefault(entry["obj_id"], []).append(image)
    if not per_object:
        sys.exit("bop_split: no training frame has a visible mask (mask_visib/)")
    for obj_id, frames in sorted(per_object.items()):
        write_scene(src_scene, os.path.join(args.out, "train", f"{obj_id:06d}"), frames)
        print(f"train/{obj_id:06d}: {len(frames)} frames ({','.join(frames)})")
    scene_name = os.path.basename(os.path.normpath(args.scene))
    write_scene(src_scene, os.path.join(args.out, "test", scene_name), test)
    print(f"test/{scene_name}: {len(test)} frames ({','.join(test)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
