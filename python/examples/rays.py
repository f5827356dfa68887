#!/usr/bin/env python3
"""Casts a fan of rays at a trioct world and prints where each one lands.

    python3 python/examples/rays.py [--url URL] [--world yard] [--origin X Y Z] [--rays N]

By default the fan hangs 30 m above the demo yard (`make run` serves it) and spreads from
60 degrees left of straight down to 60 degrees right, plus one ray pointing up, which
misses. Run from the build tree with PYTHONPATH=build/python, or anywhere once installed.
The bus is --url, else $LCM_DEFAULT_URL, else LCM's default: inside tests/e2e/netns.sh
only, for udpm.
"""

import argparse
import math
import sys

import numpy as np

import trioct


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("--url", help="the LCM bus (default: $LCM_DEFAULT_URL, else LCM's default)")
    ap.add_argument("--world", default="yard")
    ap.add_argument("--origin", type=float, nargs=3, default=[0.0, 0.5, 30.0], metavar=("X", "Y", "Z"))
    ap.add_argument("--rays", type=int, default=9, help="rays in the fan (default 9)")
    args = ap.parse_args()

    # Directions in the x-z plane, -60..60 degrees from straight down; one shared origin.
    angles = np.radians(np.linspace(-60, 60, args.rays)) if args.rays > 1 else np.zeros(1)
    dirs = np.column_stack([np.sin(angles), np.zeros_like(angles), -np.cos(angles)])
    dirs = np.vstack([dirs, [0.0, 0.0, 1.0]])

    try:
        with trioct.connect(args.url) as c:
            r = c.rays(args.world, args.origin, dirs)
    except trioct.Error as e:
        print("trioct: %s" % e, file=sys.stderr)
        return 1

    print("%d rays from (%g %g %g) at %s: %d hit" % (len(r), *args.origin, args.world, r.hit.sum()))
    for i in range(len(r)):
        angle = "up" if i == len(r) - 1 else "%+.0f deg" % math.degrees(angles[i])
        if r.hit[i]:
            print("  %-8s t = %8.4f  point (%8.3f %8.3f %8.3f)  normal (%6.3f %6.3f %6.3f)  %s triangle %d"
                  % (angle, r.t[i], *r.point[i], *r.normal[i], r.objects[r.object[i]], r.triangle[i]))
        else:
            print("  %-8s miss" % angle)
    return 0


if __name__ == "__main__":
    sys.exit(main())
