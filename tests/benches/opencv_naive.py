#!/usr/bin/env python3
"""OpenCV's naive pipeline on a clip's chips, single-threaded, beside imade's criterion numbers.

The naive pipeline per chip: Otsu threshold (the body is darker than the sky), 8-connected
connectedComponentsWithStats, the largest component, its moments and minAreaRect (on its
bounding box). Each step is timed in the thread's CPU time, like imade's benchmarks, as the mean
per chip over repeated passes through every chip of the clip. With --criterion, the times of
imade's `stages` benchmarks are read from criterion's estimates and the ratios printed.

Usage: opencv_naive.py CLIP_DIR [--criterion DIR] [--seconds S] [--json OUT]
"""

import argparse
import glob
import json
import os
import platform
import sys
import time

import cv2
import numpy as np


def load_chips(clip_dir):
    paths = sorted(glob.glob(os.path.join(clip_dir, "chips", "*.png")))
    if not paths:
        sys.exit(f"no chips in {clip_dir}/chips")
    chips = [cv2.imread(p, cv2.IMREAD_UNCHANGED) for p in paths]
    for p, c in zip(paths, chips):
        if c is None or c.ndim != 2:
            sys.exit(f"{p}: not a grayscale chip")
    return chips


def threshold(chip):
    return cv2.threshold(chip, 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)[1]


def label(binary):
    return cv2.connectedComponentsWithStats(binary, connectivity=8)


def naive_frame(chip):
    """Threshold, label, the largest component's moments and minimum-area rectangle."""
    binary = threshold(chip)
    n, labels, stats, _ = label(binary)
    if n < 2:
        return None
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x, y, w, h = stats[k, :4]
    component = cv2.compare(labels[y : y + h, x : x + w], int(k), cv2.CMP_EQ)
    moments = cv2.moments(component, binaryImage=True)
    rect = cv2.minAreaRect(cv2.findNonZero(component))
    return moments, rect


def time_per_item(f, items, seconds):
    """Mean thread CPU time per item, ns: passes over all items until `seconds` have passed;
    the mean over passes, and the fastest pass."""
    for item in items:
        f(item)
    passes = []
    start = time.thread_time_ns()
    while not passes or time.thread_time_ns() - start < seconds * 1e9:
        t0 = time.thread_time_ns()
        for item in items:
            f(item)
        passes.append((time.thread_time_ns() - t0) / len(items))
    return {"mean_ns": float(np.mean(passes)), "min_ns": float(np.min(passes)), "passes": len(passes)}


def criterion_estimate(criterion_dir, bench):
    """The time per iteration criterion reports (its slope, else its mean), ns."""
    path = os.path.join(criterion_dir, "stages", bench, "new", "estimates.json")
    try:
        with open(path) as f:
            estimates = json.load(f)
    except FileNotFoundError:
        return None
    return (estimates.get("slope") or estimates["mean"])["point_estimate"]


def fmt(ns):
    return f"{ns / 1000:9.1f} us" if ns is not None else "        -"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clip_dir")
    parser.add_argument("--criterion", help="criterion's output folder (target/criterion)")
    parser.add_argument("--seconds", type=float, default=3.0, help="timing per step, s")
    parser.add_argument("--json", help="write the numbers here")
    args = parser.parse_args()

    cv2.setNumThreads(1)
    chips = load_chips(args.clip_dir)
    binaries = [threshold(c) for c in chips]
    opencv = {
        "threshold": time_per_item(threshold, chips, args.seconds),
        "label": time_per_item(label, binaries, args.seconds),
        "frame": time_per_item(naive_frame, chips, args.seconds),
    }
    imade = {}
    if args.criterion:
        for bench in ["background", "label", "detect", "extremes", "closed_form", "table_match", "frame", "frame_table"]:
            imade[bench] = criterion_estimate(args.criterion, bench)

    h, w = chips[0].shape
    print(f"\n{len(chips)} chips of {w} x {h} from {args.clip_dir}; OpenCV {cv2.__version__}, "
          f"{cv2.getNumThreads()} thread, Python {platform.python_version()}; "
          f"thread CPU time per chip; load average {os.getloadavg()[0]:.1f}")
    print("\nOpenCV naive pipeline")
    print(f"  threshold (Otsu)                        {fmt(opencv['threshold']['mean_ns'])}")
    print(f"  connectedComponentsWithStats            {fmt(opencv['label']['mean_ns'])}")
    print(f"  whole (threshold, label, moments, rect) {fmt(opencv['frame']['mean_ns'])}")
    summary = {"chips": len(chips), "size": [w, h], "opencv_version": cv2.__version__,
               "opencv": opencv, "imade_ns": imade}
    if imade:
        print("\nimade (criterion, `cargo bench -p imade-tests --bench stages`)")
        names = {"background": "sky model and noise", "label": "labeling (threshold and runs)",
                 "detect": "segmentation (model, labeling, selection)", "extremes": "extremes and diameter",
                 "closed_form": "closed form", "table_match": "table match",
                 "frame": "whole frame (Pipeline::process)", "frame_table": "whole frame with the table"}
        for bench, label_text in names.items():
            if imade.get(bench) is not None:
                print(f"  {label_text:<40}{fmt(imade[bench])}")
        ratios = {}
        if imade.get("frame"):
            ratios["frame_vs_opencv_naive"] = imade["frame"] / opencv["frame"]["mean_ns"]
            ratios["frames_per_s"] = 1e9 / imade["frame"]
        if imade.get("frame_table"):
            ratios["frame_table_vs_opencv_naive"] = imade["frame_table"] / opencv["frame"]["mean_ns"]
            ratios["frames_per_s_table"] = 1e9 / imade["frame_table"]
        if imade.get("label"):
            ratios["label_vs_opencv_ccws"] = imade["label"] / opencv["label"]["mean_ns"]
            ratios["label_vs_opencv_threshold_ccws"] = imade["label"] / (
                opencv["label"]["mean_ns"] + opencv["threshold"]["mean_ns"])
        summary["ratios"] = ratios
        print("\nratios (imade / OpenCV; goals on one core for 256 x 256 chips)")
        goal = lambda ok: "meets the goal" if ok else "MISSES the goal"
        if "frame_vs_opencv_naive" in ratios:
            r = ratios["frame_vs_opencv_naive"]
            print(f"  whole frame / naive pipeline            {r:9.2f}   (goal <= 1: {goal(r <= 1.0)})")
        if "frame_table_vs_opencv_naive" in ratios:
            r = ratios["frame_table_vs_opencv_naive"]
            print(f"  whole frame with table / naive pipeline {r:9.2f}")
        if "label_vs_opencv_ccws" in ratios:
            r = ratios["label_vs_opencv_ccws"]
            print(f"  labeling / connectedComponentsWithStats {r:9.2f}   (goal <= 1.5: {goal(r <= 1.5)})")
            print(f"  labeling / threshold + CCWS             {ratios['label_vs_opencv_threshold_ccws']:9.2f}")
        if "frames_per_s" in ratios:
            f = ratios["frames_per_s"]
            print(f"  imade frames/s                          {f:9.0f}   (goal >= 5000: {goal(f >= 5000)})")
        if "frames_per_s_table" in ratios:
            print(f"  imade frames/s with the table           {ratios['frames_per_s_table']:9.0f}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(summary, f, indent=2)


if __name__ == "__main__":
    main()
