"""What Dask's own periodic work costs: the CPU an idle LocalCluster of cluster.connect takes,
with Dask's defaults and with Snell's (farm/cluster.py QUIET), in turn.

    .venv/bin/python tools/measure_dask_idle.py [--workers 2] [--seconds 15] [--rounds 2]

For each round and each config, starts the cluster, waits for its workers and two seconds more,
then reads the CPU seconds (user + system) of the client process (which also runs the scheduler
and the nannies) and of each worker over the given seconds, and prints them as a percentage of
one processor.
"""
import argparse
import os
import resource
import time


def process_cpu(pid: int) -> float:
    """A process's user + system CPU seconds (/proc)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def own_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def idle(cluster, workers: int, seconds: float) -> tuple[float, float]:
    """(the workers' CPU seconds, the client's) over `seconds` of an idle session."""
    with cluster.connect(None, workers) as client:
        cluster.check_workers(client)
        pids = list(client.run(os.getpid).values())
        time.sleep(2.0)
        workers_before, client_before = sum(map(process_cpu, pids)), own_cpu()
        time.sleep(seconds)
        return sum(map(process_cpu, pids)) - workers_before, own_cpu() - client_before


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    from snell.farm import cluster
    quiet = dict(cluster.QUIET)
    print(f"idle LocalCluster of {args.workers} workers, {args.seconds:g} s a run; "
          "% of one processor")
    print(f"{'config':10} {'workers':>8} {'client':>8} {'total':>8}")
    for _ in range(args.rounds):
        for name, config in (("dask", {}), ("snell", quiet)):
            cluster.QUIET = config
            worker_s, client_s = idle(cluster, args.workers, args.seconds)
            print(f"{name:10} {100 * worker_s / args.seconds:8.2f} "
                  f"{100 * client_s / args.seconds:8.2f} "
                  f"{100 * (worker_s + client_s) / args.seconds:8.2f}", flush=True)


if __name__ == "__main__":
    main()
