"""A class's data and its teacher key: ``pendulum-accel lab make-class --secret FILE --groups N --out DIR``.

The key is TEMPLATE (and GROUP_TEMPLATE per group) filled with numbers computed from the class's runs:
the template holds no typed figure (test_lab checks), so it cannot drift from the code. Teacher material:
not part of the installed package.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from string import Template

from lab_teacher.answers import (
    MAX_LAG,
    Answer,
    exercise2,
    fit_swing,
    load_csv,
    measure_bias,
    measure_group,
    period_guess_of,
)
from lab_teacher.classdata import (
    DRIVE_RUNS,
    DRIVE_SETTLE,
    DRIVE_WINDOW,
    GroupRuns,
    draw,
    group_names,
    read_secret,
    simulate_group,
    write_group,
)
from pendulum_accel import ParameterError
from pendulum_accel.cli.output import check_output_dir

STUDENT_DOCS = Path(__file__).resolve().parent.parent / "docs" / "lab"
GRADE_SIGMAS = 2.0  # a value is right within this many of the group's own σ
SIGMA_FACTOR = 2.0  # and its σ within this factor of the key's
PERIOD_ERROR = 0.01  # s: a period read off a plot is this far off; the key shows what it does to the bias
AMPLITUDE_SHIFT = 16  # ω(A) ≈ ω₀ (1 − A²/16): the pendulum's first correction for a finite amplitude A
TABLE_ROW = re.compile(
    r"^\| `(\w+)` \| [^|]* \| (\S+) ± (\S+) \| [^|]* \| [^|]* \| [^|]* \|$",
    re.MULTILINE,
)
READING_ROW = re.compile(r"^\| `(\w+)` \| [^|]* \| ([^|±\s]+) \| [^|]* \|$", re.MULTILINE)

TEMPLATE = Template(
    """# Teacher key: class `${class_name}`

Written by `pendulum-accel lab make-class` with the class's secret: do not hand this file out. Each group's
folder (`${groups_list}`) holds only its measured data and `data/params.json`; the hidden parameters
below (the car's acceleration in exercise one, the release angle in exercise two, the stretches of the city
cycle in exercise three, the noise seeds) come from HMAC-SHA256(secret, "${class_name}/group"), so the
folders cannot be regenerated without the secret.

## How to grade

Graded are exactly the worksheet's value ± σ blanks, which the student notebook prints, ${graded_count}
answers a group (exercise one: ω, θ_eq, a, g and the frequency ratio; exercise two: the bias over whole
swings; exercise three: the RMS of a(t) itself, and each estimator's RMS error and delay). The key's value
was measured from the same folder by the worked solution (`lab_teacher/solution.ipynb`), the way the
notebook says.
A group's x ± σ_x is **right** when

- |x − key| ≤ ${grade} σ_x (the group's own σ, not the key's), and
- σ_x lies between the key's σ divided by ${factor} and multiplied by ${factor}: a σ far below the key's
  has left out a source (in exercise two, the window), one far above has not used all the data.

The "hidden truth" column is what the simulator was set to. The key's value should lie within a few of
its σ of it; the column "off" gives (key − truth)/σ. Exercise three has no hidden truth: the RMS errors
and delays are properties of the estimators, measured on the group's ${runs} stretches of ${window} s
of the drive after their first ${settle} s (the bob starts hanging and the estimators start from
nothing), the delay as the lag from ${lag_min} to ${lag_max} s minimising the RMS over those same
samples, and σ is the standard error over the stretches (for a delay, with beside it the
${lag_rounding} s rms rounding of a lag read in whole samples, alike on every stretch).

Each group's second table lists what the worksheet asks without a σ (readings off a plot, predictions,
the parts of a σ, the whole-record mean): for the discussion, not graded.

${groups}

## Notes for the discussion

- **Exercise one.** The fit's σ comes from the residual (the sensor's noise); the finite amplitude
  lowers ω by ${amp_rule} (relative): ${amp_shift} for group `${first_group}`'s A = ${amp} rad, against
  its fit's σ_ω/ω = ${omega_rel_sigma}. It is the first systematic error a quieter sensor would meet.
- **Exercise two.** The average runs from the first to the last maximum of θ found in the data, so both
  ends sit at the same phase and the period read off the plot only tells where to look: in group
  `${first_group}`, a period off by ${period_error} s moves the bias by ${period_shift} m/s² (its σ:
  ${bias_sigma} m/s²). Averaging over the whole record instead cuts a swing: each group's
  `ex2_bias_whole` gives where that mean lands. The bias is above the second-order prediction by the
  fourth-order term (relative size ~A²), and positive because tan is convex (Jensen:
  ⟨g tan θ⟩ > g tan ⟨θ⟩).
- **Exercise three.** `instant` carries the swing (the pendulum rings at its natural frequency with
  ζ = ${zeta}); `period_mean` removes the swing and lags by about ${half_period} s (the drive pendulum's
  period is ${drive_period} s; group `${first_group}` measured ${period_mean_delay} s); the model-based
  estimators follow the drive with a small delay.

## Extensions (optional, not graded)

A and C go further with results of the lecture (the elastic string, the frequency's dependence on the
amplitude); B and D go beyond it.

- **A. A stiffer string.** As k grows the angle converges to the rigid pendulum's like k⁻¹, the stretch's
  departure from T_rigid/k like k⁻²; the planner's fixed-step RK4 costs the same until the radial mode
  √(k/m) reaches its stability limit, then grows like √k; an adaptive method grows from the start.
- **B. Road grade.** On the `hill` scene (grade β, constant speed, true a zero) every estimator reads
  g tan β = ${hill_reading} m/s². A level car accelerating at g tan β reads the same; its period and
  tension tell it from the hill (level over hill: period √(cos β) = ${hill_period_ratio}, tension
  sec β = ${hill_tension_ratio}).
- **C. The exact period.** The period grows with amplitude as the complete elliptic integral says;
  `pendulum-accel lecture frequency` checks a group's own measurement afterwards.
- **D. Chaos.** Two runs of `resonant_drive` one ulp apart in θ0 part at a time that
  `pendulum-accel lecture butterfly` prints (predicted by the planner, and observed); from then on the
  inputs no longer predict θ.
"""
)

GROUP_TEMPLATE = Template(
    """## Group `${group}`

Hidden: exercise one a = ${accel} m/s² (released ${offset} rad beyond θ_eq); exercise two released at
θ0 = ${release} rad (a = ${bias_accel} m/s², which the group is given); exercise three stretches from
${starts} s into the cycle.

| answer | quantity | key (value ± σ) | unit | hidden truth | off |
|---|---|---|---|---|---|
${rows}

Not graded (asked without a σ):

| reading | quantity | key | unit |
|---|---|---|---|
${readings}
"""
)


def truths(runs: GroupRuns, guess: float | None = None) -> dict[str, float]:
    """The hidden values: the set a, g, the lecture's ratio, and exercise two's bias on the noise-free θ."""
    d = runs.draw
    g = runs.swing.scene.pendulum.gravity
    rel = runs.released
    period = period_guess_of(rel.t, rel.theta_measured) if guess is None else guess
    clean = measure_bias(rel.t, rel.theta_true, d.bias_accel, g, rel.scene.sensor.noise_std, period)
    return {
        "ex1_theta_eq": math.atan2(d.accel, g),
        "ex1_omega": (math.hypot(g, d.accel) / runs.swing.scene.pendulum.length) ** 0.5,
        "ex1_a": d.accel,
        "ex1_g": g,
        "ex1_ratio": (math.hypot(g, d.accel) / g) ** 0.5,
        "ex2_bias": clean.bias,
    }


def _row(a: Answer, truth: float | None) -> str:
    """One row of a group's graded table: name, label, value ± σ, unit, truth, (key − truth)/σ."""
    if truth is None:
        return f"| `{a.name}` | {a.label} | {a.text()} | {a.unit} | — | — |"
    return (
        f"| `{a.name}` | {a.label} | {a.text()} | {a.unit} | {truth:.{a.digits + 1}f} | "
        f"{(a.value - truth) / a.sigma:+.1f}σ |"
    )


def _reading_row(a: Answer) -> str:
    """One row of a group's table of what is not graded: name, label, value, unit."""
    return f"| `{a.name}` | {a.label} | {a.reading()} | {a.unit or '—'} |"


def render_group(runs: GroupRuns, found: Mapping[str, Answer]) -> str:
    """A group's section of the key: its hidden draw, its graded answers, what is listed ungraded."""
    d = runs.draw
    truth = truths(runs)
    return GROUP_TEMPLATE.substitute(
        group=d.group,
        accel=f"{d.accel:.4f}",
        offset=f"{d.offset:.4f}",
        release=f"{d.release:+.4f}",
        bias_accel=f"{d.bias_accel:.4f}",
        starts=", ".join(f"{s:g}" for s in d.drive_starts),
        rows="\n".join(_row(a, truth.get(a.name)) for a in found.values() if a.graded),
        readings="\n".join(_reading_row(a) for a in found.values() if not a.graded),
    )


def render_key(class_name: str, groups: Sequence[tuple[GroupRuns, Path, Mapping[str, Answer]]]) -> str:
    """The whole key: the class's header and grading rule, one section per group, the discussion notes."""
    first_runs, first_folder, first = groups[0]
    data = first_folder / "data"
    rel = load_csv(data / "released.csv")
    guess = period_guess_of(rel["t_s"], rel["theta_rad"])
    shifted = {a.name: a for a in exercise2(data, guess + PERIOD_ERROR)}
    bias = first["ex2_bias"]
    swing = load_csv(data / "swing.csv")
    fit = fit_swing(swing["t_s"], swing["theta_rad"])
    hill = _hill_ratios()
    drive = first_runs.drives[0].scene.pendulum
    drive_period = 2.0 * math.pi * math.sqrt(drive.length / drive.gravity)  # small swings, a ≈ 0
    return TEMPLATE.substitute(
        class_name=class_name,
        groups_list="`, `".join(r.draw.group for r, _, _ in groups),
        graded_count=f"{sum(a.graded for a in first.values())}",
        grade=f"{GRADE_SIGMAS:g}",
        factor=f"{SIGMA_FACTOR:g}",
        runs=f"{DRIVE_RUNS}",
        window=f"{DRIVE_WINDOW:g}",
        settle=f"{DRIVE_SETTLE:g}",
        lag_min=f"{0:g}",
        lag_max=f"{MAX_LAG:g}",
        groups="\n".join(render_group(r, found) for r, _, found in groups),
        first_group=first_runs.draw.group,
        amp_rule=f"A²/{AMPLITUDE_SHIFT}",
        amp=f"{fit.amplitude:.3f}",
        amp_shift=f"{fit.amplitude**2 / AMPLITUDE_SHIFT:.1e}",
        omega_rel_sigma=f"{fit.omega_sigma / fit.omega:.1e}",
        period_error=f"{PERIOD_ERROR:g}",
        period_shift=f"{abs(shifted['ex2_bias'].value - bias.value):.2g}",
        bias_sigma=f"{bias.sigma:.1e}",
        zeta=f"{drive.damping / (2.0 * math.sqrt(drive.gravity / drive.length)):.3f}",
        half_period=f"{drive_period / 2.0:.2f}",
        drive_period=f"{drive_period:.2f}",
        period_mean_delay=first["ex3_delay_period_mean"].text(),
        lag_rounding=f"{1.0 / (first_runs.drives[0].scene.sensor.rate_hz * math.sqrt(12.0)):.4f}",  # Δt/√12
        **hill,
    )


def _hill_ratios() -> dict[str, str]:
    """Extension B's formula values for the bundled hill scene: g tan β, √(cos β), sec β."""
    from pendulum_accel import load_scene

    hill = load_scene("hill")
    beta, g = math.atan(hill.grade), hill.pendulum.gravity
    return {
        "hill_reading": f"{g * math.tan(beta):.4f}",
        "hill_period_ratio": f"{math.sqrt(math.cos(beta)):.5f}",
        "hill_tension_ratio": f"{1.0 / math.cos(beta):.5f}",
    }


def parse_key(text: str) -> dict[str, dict[str, tuple[float, float]]]:
    """{group: {answer: (value, σ)}} from the key's tables."""
    out: dict[str, dict[str, tuple[float, float]]] = {}
    for section in re.split(r"^## Group `", text, flags=re.MULTILINE)[1:]:
        group = section.split("`", 1)[0]
        out[group] = {m.group(1): (float(m.group(2)), float(m.group(3))) for m in TABLE_ROW.finditer(section)}
    return out


def parse_readings(text: str) -> dict[str, dict[str, float]]:
    """{group: {reading: value}} from the key's tables of what is not graded."""
    out: dict[str, dict[str, float]] = {}
    for section in re.split(r"^## Group `", text, flags=re.MULTILINE)[1:]:
        group = section.split("`", 1)[0]
        out[group] = {m.group(1): float(m.group(2)) for m in READING_ROW.finditer(section)}
    return out


def make_class(secret_path: Path, count: int, out: Path, class_name: str) -> Path:
    """Write one folder and zip per group under ``out`` and the key ``out/teacher_key.md``; the key's path.

    ``out`` must not exist yet (nothing is overwritten) and its parent must, as every command's directory
    output (cli.output.check_output_dir: nothing is created above the path asked for); on an error nothing
    is left behind.
    """
    secret = read_secret(secret_path)
    names = group_names(count)
    if not re.fullmatch(r"[\w.-]+", class_name):
        raise ParameterError(f"--class must be letters, digits, '.', '_' or '-', got {class_name!r}")
    if out.exists():
        raise ParameterError(f"{out} exists already: give a new --out directory (nothing is overwritten)")
    check_output_dir(out)
    staging = out.with_name(out.name + ".partial")
    if staging.exists():
        raise ParameterError(f"{staging} exists (an interrupted make-class?): remove it first")
    try:
        staging.mkdir()
        groups = []
        for name in names:
            runs = simulate_group(draw(secret, class_name, name))
            folder = staging / name
            write_group(runs, folder, STUDENT_DOCS)
            groups.append((runs, folder, measure_group(folder / "data")))
        (staging / "teacher_key.md").write_text(render_key(class_name, groups), encoding="utf-8")
        staging.rename(out)
    finally:
        if staging.exists():
            import shutil

            shutil.rmtree(staging)
    return out / "teacher_key.md"
