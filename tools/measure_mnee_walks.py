#!/usr/bin/env python3
"""Why manifold walks fail (tracer/mnee.py): renders a scene of tests/support/sds_scenes.py with
its shadow-caustics flags through a copy of mnee.stage that records, for each chain, how many
refracting vertices its seed segment collected, every rejected Newton step's cause and the
walk's exit; prints them per chain length and a few failing walks' geometry.

    .venv/bin/python tools/measure_mnee_walks.py [--scene tumbler] [--size 16] [--spp 64]
        [--show 3] [--threads 1]

A rejected step's cause is its first vertex's (in chain order): its projection ray met nothing,
another object, another face of its own object (labelled by the tube's parts on the tumbler:
outer and inner wall, top and bottom rim), or the projected vertices stop refracting (a
neighbour on the wrong side of a shading normal). Exits: converged (and its segments free or
not), the step below MIN_STEP, no progress, a singular Jacobian, MAX_ITERATIONS, and the probe's
own (no caster on the seed segment, a non-refracting caster or no room, too many surfaces).
The straight seed's walk is summarised (as Cycles' would be), and the walks from refracted
seeds (mnee.reseed) where it failed. Measurement only: the stage a render uses is mnee.stage,
untouched.
"""
from __future__ import annotations

import argparse
import collections
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def part_of(mesh, tri):
    """A label for triangle tri: the tube's part by its face normal and height (the table and
    other objects' triangles by object id)."""
    if tri < 0:
        return "nothing"
    n = mesh.face_normal[tri]
    c = mesh.corners[tri].mean(0)
    if abs(n[2]) > 0.9:
        if c[2] < 1e-3 and abs(c[0]) + abs(c[1]) > 0.9:
            return "table"
        return "top rim" if c[2] > 0.45 else "bottom rim"
    radial = c[:2] / max(np.linalg.norm(c[:2]), 1e-9)
    return "outer wall" if float(n[:2] @ radial) > 0.0 else "inner wall"


class Walks:
    """Per-chain records of one render."""

    def __init__(self):
        self.records = []

    def stage(self, geometry, tables, lights, mats, albedo_tables, fresnel_model, depth, limits,
              clamp, n_active, active, paths, prim, u, v, radiance, without, scratch):
        """mnee.stage's steps, with each chain's rejections and exit recorded."""
        from snell.tracer import mnee
        chains = mnee.chains_for(n_active)
        mesh = geometry.mesh
        n = mnee.seed_chains(tables, lights, mesh, mats, depth, limits, clamp, n_active, active,
                             paths, prim, u, v, chains)
        if n == 0:
            return 0
        recs = [{"exit": None, "rejected": collections.Counter(), "iterations": 0,
                 "x0": chains.x0[c].copy(), "y": chains.y[c].copy()} for c in range(n)]
        self._probe(mnee, geometry, tables, mesh, mats, chains, n, recs)
        self._seeds(mesh, chains, range(n), recs)
        self._walk(mnee, geometry, tables, mesh, mats, chains, n, recs)
        if mnee.reseed(chains, n):
            again = np.flatnonzero(chains.bent[:n])
            for c in again:
                recs[c]["straight"] = (recs[c]["k"], recs[c]["exit"], recs[c]["seed"])
                recs[c]["exit"], recs[c]["rejected"] = None, collections.Counter()
                recs[c]["straight rays"] = recs[c].pop("rays", 0)
                recs[c].pop("min step", None)
            self._probe(mnee, geometry, tables, mesh, mats, chains, n, recs)
            self._seeds(mesh, chains, again, recs)
            self._walk(mnee, geometry, tables, mesh, mats, chains, n, recs)
        delivered = self._finish(mnee, geometry, tables, lights, mesh, fresnel_model, chains, n,
                                 recs, radiance, without)
        self.records.extend(recs)
        return delivered

    @staticmethod
    def _seeds(mesh, chains, which, recs):
        for c in which:
            k = int(chains.k[c])
            recs[c]["k"] = k
            recs[c]["seed"] = [(chains.pos[c, i].copy(), part_of(mesh, chains.prim[c, i]))
                               for i in range(k)]
            # The first seed vertex whose neighbours are on one side of its shading normal
            # (newton_accept's still_refracts of the seed itself): -1 where none.
            ends = [chains.x0[c]] + [chains.pos[c, i] for i in range(k)] + [chains.y[c]]
            recs[c]["bad vertex"] = next(
                (i for i in range(k) if np.dot(chains.n[c, i], ends[i] - ends[i + 1])
                 * np.dot(chains.n[c, i], ends[i + 2] - ends[i + 1]) >= 0.0), -1)

    def _probe(self, mnee, geometry, tables, mesh, mats, chains, n, recs):
        for _ in range(mnee.MAX_PROBE_HITS):
            m = mnee.probe_rays(chains, n)
            if m == 0:
                break
            hit, hu, hv, ht = geometry.intersect(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
            k_before = chains.k[:n].copy()
            mnee.probe_hits(tables, mesh, mats, chains, m, hit, hu, hv, ht)
            for j in range(m):
                c = chains.owner[j]
                if chains.state[c] == mnee.FAILED and recs[c]["exit"] is None:
                    recs[c]["exit"] = ("probe: no caster on the seed segment" if k_before[c] == 0
                                       else "probe: non-refracting caster or no room")
        for c in range(n):
            if chains.state[c] == mnee.PROBING:
                recs[c]["exit"] = "probe: more surfaces than probed"
        chains.state[:n][chains.state[:n] == mnee.PROBING] = mnee.FAILED

    def _walk(self, mnee, geometry, tables, mesh, mats, chains, n, recs):
        for it in range(mnee.MAX_ITERATIONS):
            solving = chains.state[:n] == mnee.SOLVING
            m = mnee.newton_rays(mesh, chains, n)
            for c in np.flatnonzero(solving):
                if chains.state[c] == mnee.FAILED:
                    recs[c]["exit"] = "singular Jacobian"
                elif chains.state[c] == mnee.CONVERGED:
                    recs[c]["iterations"] = it
            if m == 0:
                break
            hit, hu, hv, _ = geometry.intersect(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
            causes = {c: self._cause(mnee, tables, mesh, chains, c, hit, hu, hv)
                      for c in np.flatnonzero(chains.state[:n] == mnee.SOLVING)}
            steps = chains.step[:n].copy()
            mnee.newton_accept(tables, mesh, mats, chains, n, hit, hu, hv)
            for c, cause in causes.items():
                recs[c]["min step"] = min(recs[c].get("min step", 1.0), chains.step[c])
                recs[c]["rays"] = recs[c].get("rays", 0) + int(chains.k[c])
                if chains.step[c] < steps[c]:
                    recs[c]["rejected"][cause] += 1
                    recs[c]["last"] = cause
                    if chains.state[c] == mnee.FAILED:
                        recs[c]["exit"] = "step below MIN_STEP"
                elif chains.state[c] == mnee.FAILED:
                    recs[c]["exit"] = "no progress"
        for c in range(n):
            if chains.state[c] == mnee.SOLVING:
                recs[c]["exit"] = "MAX_ITERATIONS"
        chains.state[:n][chains.state[:n] == mnee.SOLVING] = mnee.FAILED

    @staticmethod
    def _cause(mnee, tables, mesh, chains, c, hit, hu, hv):
        """Why chain c's step would be rejected (None: it would not)."""
        j0 = chains.first_ray[c]
        for i in range(chains.k[c]):
            tri = hit[j0 + i]
            own = chains.prim[c, i]
            if tri < 0:
                return f"v{i} projection meets nothing"
            if tables.tri_object[tri] != tables.tri_object[own]:
                return f"v{i} projection meets another object ({part_of(mesh, tri)})"
            if part_of(mesh, tri) != part_of(mesh, own):
                return f"v{i} projection {part_of(mesh, own)} -> {part_of(mesh, tri)}"
            chains.new_prim[c, i] = tri
            chains.new_u[c, i] = hu[j0 + i]
            chains.new_v[c, i] = hv[j0 + i]
        if not mnee.still_refracts(mesh, chains, c, chains.k[c]):
            return "stops refracting"
        return None

    def _finish(self, mnee, geometry, tables, lights, mesh, fresnel_model, chains, n, recs,
                radiance, without):
        converged = chains.state[:n] == mnee.CONVERGED
        m = mnee.visibility_rays(mesh, chains, n)
        if m:
            hit, _, _, ht = geometry.intersect(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
            mnee.check_segments(tables, mesh, chains, n, hit, ht)
        for c in np.flatnonzero(converged):
            recs[c]["exit"] = ("converged" if chains.state[c] == mnee.CONVERGED
                               else "converged, a segment blocked")
        m = mnee.light_rays(mesh, chains, n)
        if m == 0:
            return 0
        blocked = geometry.occluded(chains.o32[:m], chains.d32[:m], chains.tmax[:m])
        mnee.deliver(lights, mats, albedo_tables, mesh.corner_normals.shape[0] > 0,
                     fresnel_model, chains, m, blocked, radiance, without, scratch)
        for j in range(m):
            recs[chains.owner[j]]["lit"] = bool(blocked[j])
        return int(np.count_nonzero(blocked[:m]))


def summary(records, show):
    """Print exits and rejection causes per chain length (the straight seed's, then those of
    the refracted seeds of the walks that failed from it), and `show` failing walks per
    length."""
    retried = [r for r in records if "straight" in r]
    print(f"\nstraight seeds: {len(records)} chains; {len(retried)} walks failed and were "
          "seeded again, refracted:")
    again = collections.Counter((r["straight"][0], " / ".join(p for _, p in r["straight"][2]),
                                 r["k"], r["exit"]) for r in retried)
    for (k0, parts, k, e), count in again.most_common(12):
        print(f"  {count:7d}  straight k {k0} ({parts}) -> refracted k {k}: {e}")
    bad = collections.Counter((r["bad vertex"], r["exit"] == "converged") for r in retried)
    print("  the refracted seeds by their first vertex that does not refract (-1: none), "
          "converged or not:", dict(bad))
    done = [r["iterations"] for r in retried if r["exit"] == "converged"]
    if done:
        print("  iterations of the refracted seeds' converged walks: quantiles 50/90/99/100%",
              np.percentile(done, [50, 90, 99, 100]))
        steps = [r.get("min step", 1.0) for r in retried if r["exit"] == "converged"]
        print("  their smallest step: quantiles 0/1/10/50%", np.percentile(steps, [0, 1, 10, 50]))
    for label, group in (("straight", [r for r in records if "straight" not in r]),
                         ("refracted", retried)):
        rays = collections.Counter()
        for r in group:
            rays["converged" if r["exit"] == "converged" else "failed"] += r.get("rays", 0)
            rays["their straight walks (failed)"] += r.get("straight rays", 0)
        print(f"  projection rays of the walks from {label} seeds: {dict(rays)}")
    rejected = sum((r["rejected"] for r in retried if r["exit"] != "converged"),
                   collections.Counter())
    print("  the rejections of the refracted seeds' failing walks:", dict(rejected.most_common(6)))
    print("\nthe straight seeds:")
    by_k = collections.defaultdict(list)
    for r in records:
        first = r.get("straight")
        by_k[first[0] if first else r["k"]].append(
            dict(r, k=first[0], exit=first[1], seed=first[2]) if first else r)
    for k in sorted(by_k):
        rs = by_k[k]
        exits = collections.Counter(r["exit"] for r in rs)
        print(f"\nk = {k}: {len(rs)} chains")
        for e, count in exits.most_common():
            print(f"  {count / len(rs):6.1%}  {count:7d}  {e}")
        if k == 0:
            continue
        failed = [r for r in rs if not r["exit"].startswith("converged")
                  and not r["exit"].startswith("probe")]
        last = collections.Counter(r.get("last") for r in failed
                                   if r["exit"] == "step below MIN_STEP")
        print("  the last rejection of walks failing below MIN_STEP:")
        for e, count in last.most_common(8):
            print(f"    {count:7d}  {e}")
        all_rej = sum((r["rejected"] for r in failed), collections.Counter())
        print("  all rejections of failing walks:")
        for e, count in all_rej.most_common(8):
            print(f"    {count:7d}  {e}")
        ok = [r for r in rs if r["exit"] == "converged"]
        if ok:
            print(f"  converged walks: mean iterations {np.mean([r['iterations'] for r in ok]):.1f}"
                  f", rejections {np.mean([sum(r['rejected'].values()) for r in ok]):.2f}")
        seeds = collections.Counter(tuple(p for _, p in r["seed"]) for r in rs)
        print("  seed chains (parts) and their convergence:")
        for parts, count in seeds.most_common(6):
            conv = sum(r["exit"] == "converged" for r in rs
                       if tuple(p for _, p in r["seed"]) == parts)
            print(f"    {count:7d}  {conv / count:6.1%}  {' / '.join(parts)}")
        for r in failed[:show]:
            print(f"  failing walk: exit {r['exit']}, x0 {np.round(r['x0'], 4)}, "
                  f"y {np.round(r['y'], 4)}, rejections {dict(r['rejected'])}")
            for p, part in r["seed"]:
                print(f"      seed vertex {np.round(p, 4)} on {part}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", default="tumbler", choices=("tumbler", "pool"))
    parser.add_argument("--size", type=int, default=16)
    parser.add_argument("--spp", type=int, default=64)
    parser.add_argument("--show", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    sys.path[:0] = [os.path.join(ROOT, "tests"), os.path.join(ROOT, "scenes")]
    from support import sds_scenes
    from snell.tracer import mnee
    from snell.tracer.integrator import Renderer
    build = {"pool": sds_scenes.pool, "tumbler": sds_scenes.tumbler}[args.scene]
    scene = sds_scenes.shadow_caustics(build(resolution=(args.size, args.size)))
    walks = Walks()
    mnee.stage = walks.stage
    settings = scene.settings(spp=args.spp, threads=args.threads, seed=1, noise_threshold=0.0)
    image = Renderer(scene, settings).render().mean()[..., 0]
    print(f"{args.scene} {args.size}x{args.size}, {args.spp} spp: image mean {image.mean():.5f}")
    summary(walks.records, args.show)


if __name__ == "__main__":
    main()
