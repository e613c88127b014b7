"""The sweep report: one self-contained HTML file (inline SVG from matplotlib's SVG backend, no
scripts, no external resources)."""

from __future__ import annotations

import html
import io
import math
from pathlib import Path

SEED_KEYS = ("config.seed",)


def _svg(fig) -> str:
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight")
    text = buf.getvalue()
    return text[text.index("<svg"):]


def condition_of(params: dict) -> str:
    """A condition: the variant's parameters except the seeds (runs that differ only in the seed
    are repetitions of one condition)."""
    items = [(k, v) for k, v in sorted(params.items()) if k not in SEED_KEYS]
    if not items:
        return "all runs"
    return ", ".join(f"{k.split('.', 1)[1] if k.startswith('scenario.') else k}={v}" for k, v in items)


def pd_curves(records: list[dict]) -> dict:
    """{(sensor, condition): [(range_lo, range_hi, frames, detected)]}, pooled over objects and
    seeds."""
    acc = {}
    for rec in records:
        if rec["status"] != "ok":
            continue
        cond = condition_of(rec["params"])
        for r in rec["rows"]:
            if r.get("gt_id") is None:
                continue
            k = (r["sensor"], cond)
            b = acc.setdefault(k, {}).setdefault((r["range_lo_m"], r["range_hi_m"]), [0, 0])
            b[0] += r["frames_in_bin"]
            b[1] += r["frames_detected"]
    return {k: sorted((lo, hi, n, d) for (lo, hi), (n, d) in v.items()) for k, v in acc.items()}


def _table(headers, rows) -> str:
    th = "".join(f"<th>{html.escape(str(h))}</th>" for h in headers)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def write_report(path: Path, spec, records: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parts = []
    ok = [r for r in records if r["status"] == "ok"]
    failed = [r for r in records if r["status"] != "ok"]
    parts.append(
        f"<p>{len(records)} variants ({len(ok)} ok, {len(failed)} failed), sensors "
        f"{', '.join(spec.sensors)}, {spec.design} design over "
        f"{', '.join(a.key for a in spec.axes) or 'no parameters'}; range bins (m) "
        f"{', '.join(f'{b:g}' for b in spec.range_bins_m)}.</p>"
    )

    curves = pd_curves(records)
    sensors = sorted({s for s, _ in curves})
    parts.append("<h2>Detection probability vs range</h2>")
    if curves:
        fig, axes = plt.subplots(1, len(sensors), figsize=(7 * len(sensors), 4.5), squeeze=False)
        for ax, sensor in zip(axes[0], sensors):
            for (s, cond), pts in sorted(curves.items()):
                if s != sensor:
                    continue
                xs = [(lo + (hi if math.isfinite(hi) else lo + (lo - spec.range_bins_m[-2]))) / 2
                      for lo, hi, _, _ in pts]
                ys = [d / n if n else float("nan") for _, _, n, d in pts]
                ax.plot(xs, ys, marker="o", label=cond)
            ax.set_title(sensor)
            ax.set_xlabel("ground-truth range, m (bin centre)")
            ax.set_ylabel("detection probability")
            ax.set_ylim(-0.02, 1.02)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=1, frameon=False)
        parts.append(_svg(fig))
        plt.close(fig)
        rows = []
        for (sensor, cond), pts in sorted(curves.items()):
            for lo, hi, n, d in pts:
                rows.append((sensor, cond, f"[{lo:g}, {hi:g})", n, d, f"{d / n:.3f}" if n else ""))
        parts.append("<details><summary>Table</summary>"
                     + _table(["sensor", "condition", "range bin, m", "frames", "detected", "P(detect)"], rows)
                     + "</details>")
    else:
        parts.append("<p>No ground-truth object in any sensor's field of view (or no successful run).</p>")

    parts.append("<h2>Range and range-rate errors of detected objects</h2>")
    errs = {}
    for rec in ok:
        for sensor, e in (rec.get("errors") or {}).items():
            d = errs.setdefault(sensor, {"range_error_m": [], "range_rate_error_mps": []})
            for k in d:
                d[k].extend(x for x in e.get(k, []) if x is not None)
    if any(v["range_error_m"] or v["range_rate_error_mps"] for v in errs.values()):
        fig, axes = plt.subplots(1, 2, figsize=(12, 4), squeeze=False)
        for ax, (k, label) in zip(axes[0], [("range_error_m", "range error, m"),
                                             ("range_rate_error_mps", "range-rate error, m/s")]):
            for sensor in sorted(errs):
                xs = errs[sensor][k]
                if xs:
                    ax.hist(xs, bins=40, alpha=0.6, label=f"{sensor} (n={len(xs)})")
            ax.set_xlabel(label)
            ax.set_ylabel("detections")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        parts.append(_svg(fig))
        plt.close(fig)
    else:
        parts.append("<p>No detections with errors.</p>")

    keys = [a.key for a in spec.axes]
    parts.append("<h2>Slowest runs</h2>")
    slow = sorted((r for r in ok if r.get("wall_s") is not None), key=lambda r: -r["wall_s"])[:10]
    parts.append(_table(["run", *keys, "wall, s", "attempts"],
                        [(r["hash"], *(r["params"].get(k) for k in keys), f"{r['wall_s']:.2f}", r["attempts"])
                         for r in slow]) if slow else "<p>None.</p>")

    parts.append(f"<h2>Failed runs ({len(failed)})</h2>")
    parts.append(_table(["run", *keys, "attempts", "error"],
                        [(r["hash"], *(r["params"].get(k) for k in keys), r["attempts"], r["error"])
                         for r in failed]) if failed else "<p>None.</p>")

    title = html.escape(f"osiris sweep: {spec.name}")
    doc = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: sans-serif; margin: 2em; max-width: 1400px; }}
table {{ border-collapse: collapse; font-size: 0.85em; margin: 0.5em 0; }}
td, th {{ border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: left; vertical-align: top; }}
td {{ white-space: pre-wrap; }}
svg {{ max-width: 100%; height: auto; }}
</style></head><body>
<h1>{title}</h1>
{''.join(parts)}
</body></html>
"""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(doc)
    tmp.replace(path)
