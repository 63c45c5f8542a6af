"""Blocks of the README: the demo job's results (``demo/summary.json``) and the fault grid of the learning
study (``learning/summary.json``)."""

from __future__ import annotations

import re

from sphere_env.evaluation.experiments.docs.base import Results, percent, renders, slash, whole


def _demo(res: Results) -> dict:
    return res.json("demo/summary.json")


@renders("demo_results")
def demo_results(res: Results) -> str:
    d = _demo(res)
    c = d["controllers"]
    per = d["episodes_per_controller"] // len(d["shell_models"])

    def wins(name: str) -> str:
        return slash(round(c[name]["per_shell"][s]["success_rate"] * per) for s in d["shell_models"])

    steps = d["train_steps"]["ppo_from_scratch"]
    rate = {name: percent(c[name]["success_rate"]) for name in c}
    return (
        f"the shipped policy {rate['ppo']} ({slash(d['shell_models'])} {wins('ppo')} of {per}, tracking RMSE "
        f"{c['ppo']['tracking_rmse_rad_s']:.2f} rad/s), the PD {rate['pd']} ({wins('pd')}, "
        f"{c['pd']['tracking_rmse_rad_s']:.2f} rad/s), zero torque {rate['zero']}, the run from scratch "
        f"({whole(steps)} env steps) {rate['ppo_from_scratch']}; the job took "
        f"{d['total_wall_s'] / 60:.1f} min after the install (training "
        f"{d['train_wall_s']['ppo_from_scratch']:.0f} s at {d['train_steps_per_s']['ppo_from_scratch']:.0f} env "
        f"steps/s, evaluation {d['eval_wall_s']:.0f} s)"
    )


@renders("demo_machine")
def demo_machine(res: Results) -> str:
    """The cores of the machine the demo ran on, from its report's ``Machine:`` line."""
    m = re.search(r"^Machine: .*?, (\d+) cores;", res.text("demo/report.md"), re.M)
    if m is None:
        raise KeyError("demo/report.md: Machine line")
    return f"{m[1]}-core"


FAULTS = {
    "sensor_noise": "sensor noise",
    "latency_1": "one control step of latency",
    "latency_2": "two steps of latency",
    "torque_saturation": "motor saturation",
    "friction_high": "joint friction × 1.5",
    "friction_low": "joint friction × 0.5",
}


@renders("fault_grid")
def fault_grid(res: Results) -> str:
    s = res.json("learning/summary.json")
    return ", ".join(
        f"{label}: {percent(s['pretrained']['faults'][k]['success_rate'])} "
        f"({percent(s['pd']['faults'][k]['success_rate'])})"
        for k, label in FAULTS.items()
    )
