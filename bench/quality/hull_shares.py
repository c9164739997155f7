#!/usr/bin/env python3
"""The tables of engine/src/geometry/scene_extent.cpp: for k = 3..64 points uniform in the unit
square, the mean and the standard deviation of the log of the area of their convex hull, from
20,000 draws each with a fixed seed. Prints two C++ initialiser lists.

Usage: bench/quality/hull_shares.py [--draws N]
Standard library only (random.Random with a fixed seed; the hull is Andrew's monotone chain).
"""
import argparse
import math
import random


def hull_area(points):
    """Area of the convex hull of an (n, 2) array (monotone chain, then the shoelace formula)."""
    pts = sorted(map(tuple, points))

    def half(seq):
        chain = []
        for p in seq:
            while len(chain) >= 2 and ((chain[-1][0] - chain[-2][0]) * (p[1] - chain[-2][1]) -
                                       (chain[-1][1] - chain[-2][1]) * (p[0] - chain[-2][0])) <= 0:
                chain.pop()
            chain.append(p)
        return chain

    hull = half(pts)[:-1] + half(reversed(pts))[:-1]
    twice = sum(hull[i][0] * hull[i - 1][1] - hull[i - 1][0] * hull[i][1] for i in range(len(hull)))
    return 0.5 * abs(twice)


def main():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    p.add_argument('--draws', type=int, default=20000)
    a = p.parse_args()
    rng = random.Random(20261128)
    means, deviations = [], []
    for k in range(3, 65):
        logs = [math.log(max(hull_area([(rng.random(), rng.random()) for _ in range(k)]), 1e-9))
                for _ in range(a.draws)]
        mean = sum(logs) / len(logs)
        means.append(mean)
        deviations.append(math.sqrt(sum((v - mean) ** 2 for v in logs) / len(logs)))
    print('kLogHullMean = {' + ', '.join(f'{m:.4f}' for m in means) + '};')
    print('kLogHullDeviation = {' + ', '.join(f'{d:.4f}' for d in deviations) + '};')


if __name__ == '__main__':
    main()
