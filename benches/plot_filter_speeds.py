"""Penetration against depth at several flow speeds on one figure, from a `porelab sweep` of
a filter scene over `flow.superficial_velocity_m_s` (each job's out/penetration.csv and the
sweep's manifest.csv). Usage: python3 plot_filter_speeds.py SWEEP_DIR OUT.svg
(Depths where no particle arrived are left off the logarithmic axis.)"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(sweep_dir, out):
    key = "flow.superficial_velocity_m_s"
    with open(f"{sweep_dir}/manifest.csv") as f:
        jobs = [(row["job"], float(row[key])) for row in csv.DictReader(f)]
    fig, ax = plt.subplots(figsize=(6, 4))
    for job, u in sorted(jobs, key=lambda j: j[1]):
        with open(f"{sweep_dir}/jobs/{job}/out/penetration.csv") as f:
            rows = [r for r in csv.DictReader(f) if float(r["penetration"]) > 0]
        z = [1e3 * float(r["depth_m"]) for r in rows]
        p = [float(r["penetration"]) for r in rows]
        se = [float(r["standard_error"]) for r in rows]
        ax.errorbar(z, p, yerr=se, marker="o", ms=3, capsize=2, label=f"U = {1e3 * u:g} mm/s")
    ax.set_yscale("log")
    ax.set_xlabel("depth along the flow (mm)")
    ax.set_ylabel("penetration P (1 standard error)")
    ax.set_title("Penetration of the bed at three flow speeds")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
