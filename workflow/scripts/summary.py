"""One table of all runs of the workflow (workflow/Snakefile, rule summary).

Per run: its status (run.json), the frames kept, the objects in the map and,
when the recording has ground truth, the scores of eval.json (objects found,
spurious, ATE, object position error median), and the wall time Snakemake
measured. Written as CSV, atomically (a temporary file renamed).
"""

import csv
import json
import os

COLUMNS = [
    "run", "status", "frames_kept", "map_objects", "true_objects", "found", "spurious",
    "ate_rmse_m", "position_error_median_m", "seconds",
]


def read_json(path):
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        return json.load(f)


def count_rows(path):
    if not os.path.exists(path):
        return ""
    with open(path) as f:
        return max(0, sum(1 for _ in f) - 1)


def seconds(benchmark):
    with open(benchmark) as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    return f"{float(rows[0]['s']):.1f}" if rows else ""


def row(name, report, benchmark):
    out = os.path.dirname(report)
    status = read_json(os.path.join(out, "run.json")).get("status", "")
    omap = read_json(os.path.join(out, "omap.json"))
    scores = read_json(os.path.join(out, "eval.json"))
    kept = os.path.join(out, "run", "frames.csv")
    frames = count_rows(kept) if os.path.exists(kept) else count_rows(
        os.path.join(out, "run", "odometry.csv"))

    def score(key, digits=None):
        if key not in scores:
            return ""
        return f"{scores[key]:.{digits}f}" if digits else scores[key]

    return {
        "run": name, "status": status, "frames_kept": frames,
        "map_objects": len(omap.get("objects", [])),
        "true_objects": score("true_objects_total"), "found": score("true_objects_found"),
        "spurious": score("spurious_objects"), "ate_rmse_m": score("ate_rmse_m", 4),
        "position_error_median_m": score("object_position_error_median_m", 4),
        "seconds": seconds(benchmark),
    }


def main(snakemake):
    rows = [row(name, report, benchmark) for name, report, benchmark in
            zip(snakemake.params.names, snakemake.input.reports, snakemake.input.benchmarks)]
    output = snakemake.output[0]
    temporary = output + ".partial"
    with open(temporary, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    os.replace(temporary, output)


main(snakemake)  # noqa: F821 (Snakemake's script object)
