#!/usr/bin/env python3
"""scripts/view_check.py on a BOP layout built here: a 100 mm cube model and a test scene
of three depth frames in which the camera looks straight at the cube 1 m away in front of
a wall at 2 m. An instance at the true pose agrees with the depth; one 40 cm nearer floats
in front of what the camera saw (violations); verdicts come from the summary; a scene the
dataset lacks is named. Environment: VIEW_CHECK_SCRIPT. Needs python3-numpy, python3-pil."""
import json
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np
from PIL import Image

SCRIPT = os.environ["VIEW_CHECK_SCRIPT"]
W, H, F = 128, 96, 100.0  # image size and focal length (px)

CUBE_PLY = """ply
format ascii 1.0
element vertex 8
property float x
property float y
property float z
element face 12
property list uchar int vertex_indices
end_header
-50 -50 -50
50 -50 -50
50 50 -50
-50 50 -50
-50 -50 50
50 -50 50
50 50 50
-50 50 50
3 0 1 2
3 0 2 3
3 4 6 5
3 4 7 6
3 0 4 5
3 0 5 1
3 1 5 6
3 1 6 2
3 2 6 7
3 2 7 3
3 3 7 4
3 3 4 0
"""


def depth_image():
    """The cube's front face (z = 950 mm) where the rays hit it, the wall (2000 mm) elsewhere."""
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    x, y = (u - W / 2) / F * 950, (v - H / 2) / F * 950
    front = (np.abs(x) <= 50) & (np.abs(y) <= 50)
    return np.where(front, 950, 2000).astype(np.uint16)


def instance(iid, z, score):
    return {"id": iid, "obj_id": 1, "R": [1, 0, 0, 0, 1, 0, 0, 0, 1], "t": [0, 0, z],
            "score": score, "fit": 0.5}


class ViewCheckTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="view_check_test_")
        root = cls.root = os.path.join(cls.tmp.name, "bop")
        os.makedirs(os.path.join(root, "models"))
        with open(os.path.join(root, "models", "obj_000001.ply"), "w") as f:
            f.write(CUBE_PLY)
        scene = os.path.join(root, "test", "000001")
        os.makedirs(os.path.join(scene, "depth"))
        cameras = {}
        for k in range(3):
            Image.fromarray(depth_image()).save(os.path.join(scene, "depth", f"{k:06d}.png"))
            cameras[str(k)] = {"cam_K": [F, 0, W / 2, 0, F, H / 2, 0, 0, 1], "depth_scale": 1.0,
                               "cam_R_w2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_w2c": [0, 0, 0]}
        with open(os.path.join(scene, "scene_camera.json"), "w") as f:
            json.dump(cameras, f)
        cls.instances = os.path.join(cls.tmp.name, "instances")
        os.makedirs(cls.instances)
        with open(os.path.join(cls.instances, "000001.json"), "w") as f:
            json.dump([instance(1, 1000, 50), instance(2, 600, 40)], f)
        cls.summary = os.path.join(cls.tmp.name, "summary.json")
        with open(cls.summary, "w") as f:
            json.dump({"multi_view": {"detections": [
                {"scene": "000001", "obj_id": 1, "score": 50, "fit": 0.5, "true_positive": True},
                {"scene": "000001", "obj_id": 1, "score": 40, "fit": 0.5,
                 "true_positive": False}]}}, f)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def run_script(self, *args):
        return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True,
                              timeout=120)

    def test_the_true_pose_agrees_and_a_floating_one_violates(self):
        out_json = os.path.join(self.tmp.name, "rows.json")
        r = self.run_script(self.root, self.instances, "--summary", self.summary, "--every", "1",
                            "--json", out_json)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(out_json) as f:
            rows = {row["id"]: row for row in json.load(f)}
        true_pose, floating = rows[1], rows[2]
        # The front face's points (a sixth of the surface) are seen, in each of 3 frames.
        self.assertGreater(true_pose["agree"], 3 * 600 / 6 * 0.7)
        self.assertLess(true_pose["v"], 0.05)
        self.assertGreater(floating["violate"], 3 * 600 / 6)
        self.assertGreater(floating["v"], 0.9)
        self.assertTrue(true_pose["true_positive"])
        self.assertFalse(floating["true_positive"])
        lines = r.stdout.strip().split("\n")
        self.assertEqual(len(lines), 2)
        self.assertTrue(lines[0].startswith("TP V=0.0"), lines[0])
        self.assertTrue(lines[1].startswith("FP V="), lines[1])

    def test_min_score_and_a_missing_scene(self):
        r = self.run_script(self.root, self.instances, "--min_score", "45")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(len(r.stdout.strip().split("\n")), 1)
        self.assertTrue(r.stdout.startswith("-- V="), r.stdout)
        other = os.path.join(self.tmp.name, "other_instances")
        os.makedirs(other, exist_ok=True)
        with open(os.path.join(other, "000009.json"), "w") as f:
            json.dump([], f)
        bad = self.run_script(self.root, other)
        self.assertEqual(bad.returncode, 2)
        self.assertIn("test/000009", bad.stderr)
        self.assertEqual(self.run_script(self.root, self.instances, "--every", "0").returncode, 2)


if __name__ == "__main__":
    unittest.main()
