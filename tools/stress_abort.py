#!/usr/bin/env python3
"""Hunt intermittent crashes (issue 31 item 9): run `snell compare`, `render` and `batch` in a loop.

    .venv/bin/python tools/stress_abort.py OUT_DIR [--runs 150] [--jobs 2] [--cold 0]
        [--variants compare,render,...]

Builds two scenes like the ones that aborted (an infinite mirror whose mirrors are Geometry
Nodes instances; glass spheres instanced over a floor under a small lamp: caustics), 128 px,
then runs commands on them and on scenes/*.blend, `--jobs` at once, with core dumps allowed
(`ulimit -c unlimited`; a core lands in the run's own directory) and PYTHONFAULTHANDLER=1. The
variants change what differs between runs: thread counts, Ctrl-C at a random moment, a standard
output that is closed or a pipe closed early, and (--cold N) N pairs of processes compiling the
kernels into one fresh cache at once. Every run is a line of OUT_DIR/runs.jsonl (command, exit
status, signal, seconds, the load average, stderr's tail, core files); a run whose exit is not
what its variant expects is an anomaly, listed at the end.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import resource
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PYTHON = sys.executable
SNELL = [PYTHON, "-m", "snell.cli"]

# Runs in a child with bpy: the two scenes, built with the scene scripts' helpers.
BUILD = r"""
import sys
sys.path.insert(0, sys.argv[1])
import bpy
import common

def instancer(name, points, instance, material):
    # A grid whose points each carry an instance of `instance` (left unrealized).
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=points[0], y_subdivisions=points[1],
                                    size=points[2], location=points[3])
    grid = bpy.context.active_object
    grid.name = name
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    inst = nodes.new("GeometryNodeInstanceOnPoints")
    shape = nodes.new(instance[0])
    for key, value in instance[1].items():
        shape.inputs[key].default_value = value
    mat = nodes.new("GeometryNodeSetMaterial")
    mat.inputs["Material"].default_value = material
    links.new(gin.outputs[0], inst.inputs["Points"])
    links.new(shape.outputs[0], mat.inputs["Geometry"])
    links.new(mat.outputs[0], inst.inputs["Instance"])
    links.new(inst.outputs[0], gout.inputs[0])
    grid.modifiers.new(name, "NODES").node_group = group
    return grid

def mirror(path):
    scene = common.reset()
    common.setup_render(scene, (128, 128), samples=128, max_bounces=32)
    common.set_world(scene, (0.05, 0.05, 0.06))
    m = common.material("Mirror", "glossy", (0.95, 0.95, 0.9), Roughness=0.0)
    floor = common.material("Floor", "diffuse", (0.6, 0.6, 0.6))
    lamp = common.material("Lamp", "emission", (1.0, 0.9, 0.8), Strength=20.0)
    common.quad("MirrorA", [(-1, -2, 0), (-1, 2, 0), (-1, 2, 2), (-1, -2, 2)], m)
    common.quad("MirrorB", [(1, -2, 0), (1, -2, 2), (1, 2, 2), (1, 2, 0)], m)
    common.quad("Floor", [(-1, -2, 0), (1, -2, 0), (1, 2, 0), (-1, 2, 0)], floor)
    common.quad("Lamp", [(-0.2, -0.2, 1.99), (-0.2, 0.2, 1.99), (0.2, 0.2, 1.99),
                         (0.2, -0.2, 1.99)], lamp)
    instancer("Cubes", (4, 4, 1.2, (0, 0.5, 0.6)),
              ("GeometryNodeMeshCube", {"Size": (0.12, 0.12, 0.12)}), m)
    common.camera(scene, (0.3, -1.9, 1.0), (-0.2, 1.0, 0.8), lens=24.0)
    common.save(path)

def glass(path):
    scene = common.reset()
    common.setup_render(scene, (128, 128), samples=128, max_bounces=12)
    common.cornell_box(light_strength=15.0 * 25, light_size=0.1)
    g = common.material("Glass", "glass", (1.0, 1.0, 1.0), IOR=1.5, Roughness=0.0)
    common.uv_sphere("GlassSphere", (0.0, 0.2, 0.5), 0.35, g)
    instancer("Drops", (3, 3, 1.0, (0, -0.3, 0.15)),
              ("GeometryNodeMeshIcoSphere", {"Radius": 0.1, "Subdivisions": 3}), g)
    common.camera(scene, (0.0, -1.7, 1.6), (0.0, 0.05, 0.2), lens=35.0)
    common.save(path)

mirror(sys.argv[2])
glass(sys.argv[3])
"""


def build_scenes(out_dir: str) -> list[str]:
    """The infinite mirror and glass caustics .blend files, built once into out_dir."""
    paths = [os.path.join(out_dir, "gn_mirror.blend"), os.path.join(out_dir, "gn_glass.blend")]
    if not all(os.path.isfile(p) for p in paths):
        subprocess.run([PYTHON, "-c", BUILD, os.path.join(ROOT, "scenes"), *paths], check=True,
                       stdout=subprocess.DEVNULL)
    return paths


def _allow_cores():
    # In the child before exec: what `ulimit -c unlimited` does in a shell; and Ctrl-C's usual
    # meaning, which a tool started in the background inherits ignored.
    resource.setrlimit(resource.RLIMIT_CORE, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def variants(names: list[str], scenes: list[str], repo: list[str], rng: random.Random):
    """One run's (variant name, argv after `snell`, Ctrl-C after seconds or None, stdout mode,
    expected exit statuses); the variant cycles through names."""
    i = 0
    while True:
        name = names[i % len(names)]
        i += 1
        threads = str(rng.choice([1, 2, 2, 4]))
        scene = rng.choice(scenes)
        any_scene = rng.choice(scenes + repo)
        small = [] if any_scene in scenes else ["--scale", "25"]
        spp = rng.choice(["128", "32", "32"])    # 128: the issue's; 32: more runs an hour
        stop, stdout, expect = None, "file", (0,)
        if name == "compare":
            argv = ["compare", scene, "--report", "{run}/report", "--spp", spp,
                    "--cycles-seeds", "8", "--threads", threads]
        elif name == "compare-repo":
            argv = ["compare", any_scene, "--report", "{run}/report", "--spp", "32",
                    "--threads", threads] + small
        elif name == "render":
            argv = ["render", any_scene, "-o", "{run}/out.exr", "--png", "{run}/out.png",
                    "--spp", spp, "--threads", threads] + small
        elif name == "batch":
            argv = ["batch", scene, "-o", "{run}/frame.exr", "--spp", "32", "--threads", threads]
        elif name == "ctrl-c-start":     # Ctrl-C in the first seconds: imports, Blender's start
            argv = ["info", rng.choice(scenes + repo)]
            stop, expect = rng.uniform(0.5, 6.0), (0, 130)
        elif name.startswith("ctrl-c"):
            command = rng.choice(["compare", "render", "batch"])
            argv = {"compare": ["compare", scene, "--report", "{run}/report", "--spp", "128",
                                "--threads", threads],
                    "render": ["render", scene, "-o", "{run}/out.exr", "--spp", "128",
                               "--threads", threads],
                    "batch": ["batch", scene, "-o", "{run}/frame.exr", "--spp", "128",
                              "--threads", threads]}[command]
            stop, expect = rng.uniform(0.2, 20.0), (0, 130)
        elif name == "closed-stdout":
            stdout = rng.choice(["closed", "broken-pipe"])
            argv = rng.choice([["render", scene, "-o", "{run}/out.exr", "--spp", "32"],
                               ["compare", scene, "--report", "{run}/report", "--spp", "32",
                                "--cycles-seeds", "2"]])
            expect = (0, 1)      # a clean error is acceptable; a signal is not
        else:
            raise SystemExit(f"unknown variant {name!r}")
        yield name, argv, stop, stdout, expect


def start(run_dir: str, argv: list[str], stdout: str, env: dict):
    """Popen of `snell argv` in run_dir; its stdout as the variant asks."""
    os.makedirs(run_dir, exist_ok=True)
    argv = [a.replace("{run}", run_dir) for a in argv]
    err = open(os.path.join(run_dir, "stderr.txt"), "wb")
    if stdout == "closed":
        out, close = None, True
    elif stdout == "broken-pipe":
        out, close = subprocess.PIPE, False
    else:
        out, close = open(os.path.join(run_dir, "stdout.txt"), "wb"), False
    preexec = _allow_cores
    if close:
        def preexec():
            _allow_cores()
            os.close(1)
    proc = subprocess.Popen(SNELL + argv, cwd=run_dir, stdout=out, stderr=err, env=env,
                            preexec_fn=preexec)
    if stdout == "broken-pipe":
        proc.stdout.close()      # nobody reads: the first write gets EPIPE
    return proc, argv


def finish(record: dict, proc, run_dir: str) -> dict:
    """The record of a finished run: exit, signal, stderr's tail, cores."""
    rc = proc.returncode
    record.update(exit=rc, signal=signal.Signals(-rc).name if rc < 0 else None,
                  seconds=round(time.monotonic() - record.pop("_t0"), 1),
                  load_end=os.getloadavg()[0])
    with open(os.path.join(run_dir, "stderr.txt"), "rb") as f:
        record["stderr_tail"] = f.read()[-1500:].decode("utf-8", "replace")
    record["cores"] = [n for n in os.listdir(run_dir) if n.startswith("core")]
    # A traceback or a fatal error is a defect whatever the exit status.
    record["anomaly"] = rc not in record["expect"] or any(
        text in record["stderr_tail"] for text in ("Traceback", "Fatal Python error"))
    return record


def hunt(out_dir: str, runs: int, jobs: int, names: list[str], seed: int, env: dict):
    """Run `runs` commands, `jobs` at a time; append each record to runs.jsonl."""
    rng = random.Random(seed)
    scenes = build_scenes(out_dir)
    repo = sorted(os.path.join(ROOT, "scenes", n) for n in os.listdir(os.path.join(ROOT, "scenes"))
                  if n.endswith(".blend"))
    plan = variants(names, scenes, repo, rng)
    log = open(os.path.join(out_dir, "runs.jsonl"), "a")
    active, done = [], 0
    while done < runs:
        while len(active) < jobs and done + len(active) < runs:
            name, argv, stop, stdout, expect = next(plan)
            run_dir = tempfile.mkdtemp(prefix=f"{name}-", dir=out_dir)
            proc, argv = start(run_dir, argv, stdout, env)
            active.append({"proc": proc, "dir": run_dir, "stop": stop, "record": {
                "variant": name, "argv": argv, "ctrl_c_after": stop and round(stop, 2),
                "stdout": stdout, "expect": list(expect), "load_start": os.getloadavg()[0],
                "_t0": time.monotonic()}})
        time.sleep(0.1)
        for run in list(active):
            proc, record = run["proc"], run["record"]
            if run["stop"] is not None and proc.poll() is None and \
                    time.monotonic() - record["_t0"] >= run["stop"]:
                proc.send_signal(signal.SIGINT)
                run["stop"] = None
            if proc.poll() is None:
                continue
            active.remove(run)
            rec = finish(record, proc, run["dir"])
            log.write(json.dumps(rec) + "\n")
            log.flush()
            done += 1
            mark = "ANOMALY " if rec["anomaly"] else ""
            print(f"{done:4d} {mark}{rec['variant']:14s} exit {rec['exit']:4d} "
                  f"{rec['seconds']:6.1f}s load {rec['load_end']:.1f} "
                  f"{' '.join(os.path.basename(a) for a in rec['argv'][:2])}", flush=True)
    return done


def cold_pairs(out_dir: str, pairs: int, env: dict) -> None:
    """`pairs` times: two renders at once, each compiling every kernel into one fresh cache."""
    scene = build_scenes(out_dir)[1]
    log = open(os.path.join(out_dir, "runs.jsonl"), "a")
    for k in range(pairs):
        cache = tempfile.mkdtemp(prefix="cold-cache-", dir=out_dir)
        procs = []
        for j in range(2):
            run_dir = tempfile.mkdtemp(prefix="cold-", dir=out_dir)
            proc, argv = start(run_dir, ["render", scene, "-o", "{run}/out.exr", "--spp", "16"],
                               "file", {**env, "SNELL_KERNEL_CACHE": cache})
            procs.append((proc, run_dir, {"variant": "cold-cache", "argv": argv, "expect": [0],
                                          "load_start": os.getloadavg()[0],
                                          "_t0": time.monotonic(), "cache": cache}))
            time.sleep(j * 0.5)
        for proc, run_dir, record in procs:
            proc.wait()
            rec = finish(record, proc, run_dir)
            log.write(json.dumps(rec) + "\n")
            log.flush()
            print(f"cold {k}: exit {rec['exit']} {rec['seconds']}s", flush=True)


def summary(out_dir: str) -> None:
    """Print runs per variant and the anomalies from runs.jsonl."""
    counts, anomalies = {}, []
    with open(os.path.join(out_dir, "runs.jsonl")) as f:
        for line in f:
            rec = json.loads(line)
            row = counts.setdefault(rec["variant"], {"runs": 0, "exits": {}})
            row["runs"] += 1
            row["exits"][str(rec["exit"])] = row["exits"].get(str(rec["exit"]), 0) + 1
            if rec["anomaly"]:
                anomalies.append(rec)
    for name, row in sorted(counts.items()):
        print(f"{name:14s} {row['runs']:4d} runs, exits {row['exits']}")
    for rec in anomalies:
        print(f"ANOMALY {rec['variant']} exit {rec['exit']} {rec['argv']}\n{rec['stderr_tail']}")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("out", help="directory for the scenes, the runs and runs.jsonl")
    p.add_argument("--runs", type=int, default=150)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--cold", type=int, default=0, help="pairs compiling into one fresh cache")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--variants", default="compare,render,ctrl-c,compare-repo,batch,"
                                         "compare,closed-stdout,render")
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    env = {**os.environ, "PYTHONFAULTHANDLER": "1"}
    if args.cold:
        cold_pairs(args.out, args.cold, env)
    if args.runs:
        hunt(args.out, args.runs, args.jobs, args.variants.split(","), args.seed, env)
    summary(args.out)


if __name__ == "__main__":
    main()
