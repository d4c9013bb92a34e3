#!/usr/bin/env python3
"""OpenCV's naive pipeline turned into a pose, per frame of a clip, written like `imade run`.

For every chip of an imade-clip/1 clip (docs/formats.md) the naive segmentation of
tests/benches/opencv_naive.py, preceded by a median background:

  1. background: the chip's median over a 31 x 31 px window (cv2.medianBlur; wider than twice
     the body's width, so it stays the sky's under the body, and narrow enough to follow haze and
     terrain gradients); the chip is flattened to 255 - (background - chip), clipped: with the
     default --polarity dark (opencv_naive.py's assumption, and every bundled clip's) only what
     is darker than its background counts, with --polarity either |background - chip| does;
  2. threshold: Otsu (opencv_naive.threshold, THRESH_BINARY_INV | THRESH_OTSU);
  3. the largest 8-connected component (opencv_naive.label, connectedComponentsWithStats).
  (A 16-bit chip is first stretched to 8 bits between its minimum and maximum.)

Its mask becomes a pose, naively (angles and frames of docs/geometry.md):

  - the mask's principal axis from its moments, its two extreme points along it; the image length
    between them is (max - min + 1) px along the axis (the extreme pixels' centres lie half a pixel
    inside the silhouette's ends);
  - the nose is the end whose last fifth of the length has fewer mask pixels (the ogive tapers,
    the fins widen the tail);
  - the slant range is the clip's range_m where filled (range_used true), else D / (the mask's
    mean width over the middle half of its length), with D the projectile's diameter;
  - T = range * (unit line of sight through the mask centroid), pinhole with the clip's fx, fy,
    cx, cy and the chip's origin chip_x0, chip_y0;
  - the tilt out of the plane perpendicular to the line of sight: cos(tilt) = image length /
    (L / range, in normalized image units), clamped to [0, 1]; the nose direction is
    cos(tilt) * (the image axis, lifted perpendicular to the line of sight) +/- sin(tilt) * (line
    of sight). The two signs are the mirror candidates of docs/geometry.md ("The yaw ambiguity").
    The naive choice is always "+", the nose pointing away from the camera (|yaw| < 90 near the
    optical axis), which is also imade's choice at the start of a clip before a range trend
    resolves it; the other candidate is yaw_alt_deg, and yaw_resolved is always false.

A frame without any component is `no_target`. Writes OUT/results.csv (imade-results/1, the
format's eleven columns) and OUT/masks/NNNNNN.png (0/255, chip-sized, the frame number in six
digits like imade's `--save-masks`), so that `imade eval CLIP --results OUT/results.csv` scores
the naive pipeline exactly as it scores imade.

Usage: opencv_naive_pose.py CLIP_DIR --out DIR [--length-m L --diameter-m D]
                             [--polarity dark|either]
       opencv_naive_pose.py --self-test
"""

import argparse
import csv
import json
import math
import os
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import opencv_naive  # noqa: E402  (the speed benchmark's threshold and labeling)

# Projectiles whose length and diameter are known here (docs/projectile.md).
PROJECTILES = {"ref-1378x80": (1.378, 0.080)}

HEADER = ("frame,status,tx_m,ty_m,tz_m,pitch_deg,yaw_deg,yaw_alt_deg,yaw_resolved,range_used,"
          "roll_deg")
END_FRACTION = 0.2  # the share of the length at each end whose mask area decides the nose


# ---------------------------------------------------------------- segmentation

BACKGROUND_KERNEL_PX = 31


def flatten(chip, polarity="dark"):
    """The median background removed, as 8 bits with the target dark on a sky of 255."""
    if chip.dtype != np.uint8:
        chip = cv2.normalize(chip, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    background = cv2.medianBlur(chip, BACKGROUND_KERNEL_PX).astype(np.float32)
    deviation = background - chip.astype(np.float32)
    deviation = np.abs(deviation) if polarity == "either" else np.maximum(deviation, 0.0)
    return (255.0 - np.minimum(deviation, 255.0)).astype(np.uint8)


def naive_mask(chip, polarity="dark"):
    """The naive mask (bool, chip-sized) or None when no component is found."""
    binary = opencv_naive.threshold(flatten(chip, polarity))
    n, labels, stats, _ = opencv_naive.label(binary)
    if n < 2:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    return labels == k


# ---------------------------------------------------------------- geometry (docs/geometry.md)

def nose_direction(pitch_deg, yaw_deg):
    p, y = math.radians(pitch_deg), math.radians(yaw_deg)
    return np.array([math.cos(p) * math.sin(y), -math.sin(p), math.cos(p) * math.cos(y)])


def attitude(n):
    """(pitch, yaw) in degrees of a unit nose direction in the camera frame."""
    return (math.degrees(math.asin(max(-1.0, min(1.0, -n[1])))),
            math.degrees(math.atan2(n[0], n[2])))


def rotation_body_to_camera(pitch_deg, yaw_deg, roll_deg):
    def rot(axis, a):
        c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
        return {"x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
                "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
                "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]
    p = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]])
    return p @ rot("z", yaw_deg) @ rot("y", pitch_deg) @ rot("x", roll_deg)


def project(camera, point):
    return (camera["cx"] + camera["fx"] * point[0] / point[2],
            camera["cy"] + camera["fy"] * point[1] / point[2])


def normalized(camera, u, v):
    """Full-frame pixel to normalized image coordinates (X/Z, Y/Z)."""
    return np.array([(u - camera["cx"]) / camera["fx"], (v - camera["cy"]) / camera["fy"]])


def pose_from_axis(camera, nose_px, tail_px, centre_px, range_m, length_m):
    """T and the two mirror candidates (pitch, yaw) from the image axis (full-frame pixels of the
    nose end, the tail end and the body's centre) at a slant range: ((T), (chosen, other)) with
    the chosen candidate the nose pointing away from the camera."""
    c = normalized(camera, *centre_px)
    sight = np.array([c[0], c[1], 1.0])
    sight /= np.linalg.norm(sight)
    t = range_m * sight
    axis_n = normalized(camera, *nose_px) - normalized(camera, *tail_px)
    image_length = float(np.linalg.norm(axis_n))  # normalized units
    lifted = np.array([axis_n[0], axis_n[1], 0.0])
    lifted -= lifted.dot(sight) * sight  # the image axis as a direction perpendicular to the sight
    lifted /= np.linalg.norm(lifted)
    cos_tilt = min(1.0, image_length * range_m / length_m)
    sin_tilt = math.sqrt(max(0.0, 1.0 - cos_tilt * cos_tilt))
    away = cos_tilt * lifted + sin_tilt * sight
    towards = cos_tilt * lifted - sin_tilt * sight
    return t, (attitude(away), attitude(towards))


# ---------------------------------------------------------------- the naive pose of one mask

def mask_pose(mask, camera, chip_x0, chip_y0, range_m, length_m, diameter_m):
    """(T, (pitch, yaw), yaw_alt, range_used) from a naive mask, or None when it has no extent."""
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    if m["m00"] < 1:
        return None
    xc, yc = m["m10"] / m["m00"], m["m01"] / m["m00"]
    theta = 0.5 * math.atan2(2.0 * m["mu11"], m["mu20"] - m["mu02"])
    ax, ay = math.cos(theta), math.sin(theta)
    rows, cols = np.nonzero(mask)
    s = (cols - xc) * ax + (rows - yc) * ay
    smin, smax = float(s.min()), float(s.max())
    length_px = smax - smin + 1.0
    lo, hi = smin - 0.5, smax + 0.5  # the silhouette's ends along the axis
    end = END_FRACTION * length_px
    area_lo = int(np.count_nonzero(s < lo + end))
    area_hi = int(np.count_nonzero(s > hi - end))
    nose_s, tail_s = (hi, lo) if area_hi < area_lo else (lo, hi)
    point = lambda sv: (chip_x0 + xc + sv * ax, chip_y0 + yc + sv * ay)
    centre = (chip_x0 + xc, chip_y0 + yc)
    range_used = range_m is not None
    if not range_used:
        middle = np.count_nonzero((s > lo + 0.25 * length_px) & (s < hi - 0.25 * length_px))
        width_px = middle / (0.5 * length_px)  # mean width over the middle half, px
        if width_px <= 0:
            return None
        # the width's direction (-ay, ax) in normalized units
        width_n = width_px * math.hypot(ay / camera["fx"], ax / camera["fy"])
        range_m = diameter_m / width_n
    t, (chosen, other) = pose_from_axis(camera, point(nose_s), point(tail_s), centre, range_m,
                                        length_m)
    return t, chosen, other[1], range_used


# ---------------------------------------------------------------- the clip

def read_clip(clip_dir):
    with open(os.path.join(clip_dir, "clip.json")) as f:
        clip = json.load(f)
    if clip.get("format") != "imade-clip/1":
        sys.exit(f"{clip_dir}/clip.json: format is not imade-clip/1")
    with open(os.path.join(clip_dir, "frames.csv"), newline="") as f:
        rows = [{k.strip(): (v or "").strip() for k, v in r.items() if k} for r in csv.DictReader(f)]
    return clip, rows


def run(clip_dir, out_dir, length_m, diameter_m, polarity):
    clip, rows = read_clip(clip_dir)
    known = PROJECTILES.get(clip.get("projectile"))
    length_m = length_m or (known and known[0])
    diameter_m = diameter_m or (known and known[1])
    if not length_m or not diameter_m:
        sys.exit(f"{clip_dir}/clip.json: projectile {clip.get('projectile')!r} is not known here; "
                 "give --length-m and --diameter-m")
    camera = clip["camera"]
    chip_w, chip_h = clip["chip"]["width"], clip["chip"]["height"]
    masks_dir = os.path.join(out_dir, "masks")
    os.makedirs(masks_dir, exist_ok=True)
    for name in os.listdir(masks_dir):  # masks belong to the results beside them
        if name.endswith(".png"):
            os.remove(os.path.join(masks_dir, name))
    counts = {}
    lines = [HEADER]
    for row in rows:
        status, pose, frame = "ok", None, row.get("frame", "")
        try:
            frame_no = int(frame)
            chip_x0, chip_y0 = int(row["chip_x0"]), int(row["chip_y0"])
            range_m = float(row["range_m"]) if row.get("range_m") else None
            if range_m is not None and not (math.isfinite(range_m) and range_m > 0):
                raise ValueError("range_m")
        except (ValueError, KeyError):
            status = "bad_row"
        if status == "ok":
            path = os.path.realpath(os.path.join(clip_dir, row.get("chip", "")))
            inside = path.startswith(os.path.realpath(clip_dir) + os.sep)
            chip = cv2.imread(path, cv2.IMREAD_UNCHANGED) if inside and row.get("chip") else None
            if chip is None or chip.ndim != 2 or chip.shape != (chip_h, chip_w):
                status = "bad_chip"
        if status == "ok":
            mask = naive_mask(chip, polarity)
            if mask is None:
                status = "no_target"
            else:
                cv2.imwrite(os.path.join(masks_dir, f"{frame_no:06d}.png"),
                            mask.astype(np.uint8) * 255)
                pose = mask_pose(mask, camera, chip_x0, chip_y0, range_m, length_m, diameter_m)
                if pose is None:
                    status = "unmeasurable"
        counts[status] = counts.get(status, 0) + 1
        if pose is None:
            lines.append(f"{frame},{status},,,,,,,false,false,")
        else:
            t, (pitch, yaw), yaw_alt, range_used = pose
            lines.append(f"{frame},ok,{t[0]:.4f},{t[1]:.4f},{t[2]:.3f},{pitch:.4f},{yaw:.4f},"
                         f"{yaw_alt:.4f},false,{str(range_used).lower()},")
    results = os.path.join(out_dir, "results.csv")
    with open(results + ".tmp", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(results + ".tmp", results)
    summary = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    print(f"{clip_dir}: {len(rows)} frames ({summary}) -> {results}")


# ---------------------------------------------------------------- self-test

def self_test():
    """docs/geometry.md's camera-frame test vector, forwards and back, and the taper rule."""
    camera = {"fx": 100000.0, "fy": 100000.0, "cx": 1023.5, "cy": 1023.5}
    t = np.array([3.0, -2.0, 1500.0])
    r = rotation_body_to_camera(30.0, -60.0, 20.0)
    expected_r = np.array([[-0.750000, 0.321747, -0.577909],
                           [-0.500000, 0.296198, 0.813798],
                           [0.433013, 0.899303, -0.061275]])
    assert np.abs(r - expected_r).max() < 2e-6, r
    n = nose_direction(30.0, -60.0)
    assert np.abs(n - [-0.750000, -0.500000, 0.433013]).max() < 1e-6 and np.allclose(r[:, 0], n)
    pixels = {(0.689, 0, 0): (1189.017, 867.231), (-0.689, 0, 0): (1257.997, 913.111),
              (0, 0, 0): (1223.500, 890.167), (-0.689, 0, 0.100): (1254.144, 918.537)}
    for b, uv in pixels.items():
        got = project(camera, t + r @ np.array(b))
        assert max(abs(got[0] - uv[0]), abs(got[1] - uv[1])) < 1e-3, (b, got, uv)
    assert np.allclose(attitude(n), (30.0, -60.0))
    # back: the nose tip, the base and the origin's pixels at the slant range |T|
    t_est, (chosen, other) = pose_from_axis(camera, pixels[(0.689, 0, 0)],
                                            pixels[(-0.689, 0, 0)], pixels[(0, 0, 0)],
                                            float(np.linalg.norm(t)), 1.378)
    assert np.abs(t_est - t).max() < 1e-3, t_est
    # yaw -60 points away (n_z > 0), so it is the naive choice; the mirror is -120 (geometry.md)
    assert abs(chosen[0] - 30.0) < 0.05 and abs(chosen[1] + 60.0) < 0.05, chosen
    assert abs(other[1] + 120.0) < 0.5 and abs(other[0] - 30.0) < 0.5, other
    # the taper: a wedge whose nose (narrow end) is on the right, pointing right and up in the
    # image (pitch > 0), seen at the range where its length is unforeshortened (yaw +90 or 90)
    mask = np.zeros((64, 128), np.uint8)
    cv2.fillPoly(mask, [np.array([[10, 40], [10, 30], [110, 22], [110, 20]], np.int32)], 1)
    pose = mask_pose(mask.astype(bool), camera, 0, 0, 1.378 * 100000.0 / 101.0, 1.378, 0.08)
    (pitch, yaw), yaw_alt = pose[1], pose[2]
    assert 0 < pitch < 15 and yaw > 0 and yaw_alt > 0, (pitch, yaw, yaw_alt)
    print("self-test passed: R_CB, n, the four pixels, (pitch, yaw) = (30, -60) recovered from "
          f"the image axis ({chosen[0]:.4f}, {chosen[1]:.4f}; mirror {other[0]:.4f}, "
          f"{other[1]:.4f}), the taper rule")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip_dir", nargs="?")
    parser.add_argument("--out", help="folder for results.csv and masks/")
    parser.add_argument("--length-m", type=float, help="projectile length (unknown projectiles)")
    parser.add_argument("--diameter-m", type=float, help="projectile diameter (unknown ones)")
    parser.add_argument("--polarity", choices=["dark", "either"], default="dark",
                        help="the target's polarity against its background (default dark)")
    parser.add_argument("--self-test", action="store_true", help="check the conventions and exit")
    args = parser.parse_args()
    if args.self_test:
        self_test()
        return
    if not args.clip_dir or not args.out:
        parser.error("CLIP_DIR and --out are required")
    cv2.setNumThreads(1)
    run(args.clip_dir, args.out, args.length_m, args.diameter_m, args.polarity)


if __name__ == "__main__":
    main()
