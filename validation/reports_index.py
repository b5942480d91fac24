"""reports/README.md: every study in one line, with its headline figure, its picture, a link,
and when and from which commit its report was made; a report made before a later change to the
code it measures is flagged. Written by scripts/main.sh at its end.

Usage: reports_index.py [reports folder]   (default: the reports/ beside this script's folder)
Run with Debian's /usr/bin/python3.
"""
import csv
import glob
import os
import re
import sys

from report_files import ROOT, git, write_text

def rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


def pct(x):
    return f"{100 * x:.2g} %"


def span(values, fmt=pct):
    values = [v for v in values if v == v]  # NaN out
    if not values:
        return "none"
    lo, hi = min(values), max(values)
    return fmt(lo) if fmt(lo) == fmt(hi) else f"{fmt(lo)} to {fmt(hi)}"


def markdown_table(path):
    """The first Markdown table of a report: its header cells and its rows of cells."""
    header, body = None, []
    with open(path) as fh:
        for line in fh:
            if not line.startswith("|"):
                if header:
                    break
                continue
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if header is None:
                header = cells
            elif not set("".join(cells)) <= set("-: "):
                body.append(dict(zip(header, cells)))
    return body


# ---- headline figures, one function per study, each from the report's own data ----

def point_headline(folder):
    table = markdown_table(os.path.join(folder, "validation.md"))
    errors = [float(r["force rel. L2"]) for r in table if "force rel. L2" in r]
    return (f"IRDM with every mode against the linear FEM on {len(errors)} scenes: force rel. L2 "
            f"{span(errors, lambda x: f'{x:.1e}')}")


def planes_headline(folder):
    data = rows(os.path.join(folder, "planes.csv"))

    def of(method, key):
        return [float(r[key]) for r in data if r["method"] == method and r[key]]
    return (f"against the nonlinear FEM over {len({r['case'] for r in data})} cases: many-vertex "
            f"contact (modal) impulse {span(of('vertex_contact_modal', 'impulse_error'))}; virtual "
            f"DOFs (nearest) impulse {span(of('vdof_nearest', 'impulse_error'))}")


def reduced_planes_headline(folder):
    data = [r for r in rows(os.path.join(folder, "planes.csv")) if r["method"].startswith("reduced")]
    best = {}
    for r in data:  # each case's most accurate reduced model, in shape
        if r["case"] not in best or float(r["displacement_error"]) < float(best[r["case"]]["displacement_error"]):
            best[r["case"]] = r
    of = lambda key: [float(r[key]) for r in best.values()]  # noqa: E731
    return (f"{len(best)} cases, each case's best reduced model against the nonlinear FEM: shape "
            f"{span(of('displacement_error'))}, impulse {span(of('impulse_error'))}, force "
            f"{span(of('force_error'))}")


def reduced_map_headline(folder):
    data = [r for r in rows(os.path.join(folder, "nonlinear.csv")) if r["method"].startswith("reduced")]
    parts = []
    for method in sorted({r["method"] for r in data}):
        of = lambda key: [float(r[key]) for r in data if r["method"] == method and r[key]]  # noqa: E731
        parts.append(f"{method} shape {span(of('displacement_error'))}, force {span(of('force_error'))}")
    return (f"{len({r['case'] for r in data})} cases against the nonlinear FEM: " + "; ".join(parts)
            if parts else "no reduced rows")


def reduced_free_headline(folder):
    data = [r for r in rows(os.path.join(folder, "first_contact.csv")) if r["method"].startswith("reduced")]
    of = lambda key: [float(r[key]) for r in data if r[key]]  # noqa: E731
    return (f"first contact, {len({r['case'] for r in data})} cases ({', '.join(sorted({r['material'] for r in data}))}), "
            f"reduced models against the nonlinear FEM: deformation {span(of('deformation_error'))}, "
            f"impulse {span(of('impulse_error'))}" if data else "no reduced rows")


def free_headline(folder):
    first = [r for r in rows(os.path.join(folder, "first_contact.csv")) if r["material"] == "50kPa"]
    lin = [r for r in rows(os.path.join(folder, "linearization.csv"))
           if r["material"] == "50kPa" and r["reference"] == "fem_neo_hookean"
           and r["method"].startswith("fem_linear")]
    route2 = [float(r["deformation_error"]) for r in first if r["method"] == "route2_modal"]
    linear = [float(r["first_deformation_error"]) for r in lin]
    return (f"50 kPa, first contact, deformation: route 2 (every mode) against the nonlinear FEM "
            f"{span(route2)}; linear elasticity itself {span(linear)}")


def free_frame_headline(folder):
    lin = [r for r in rows(os.path.join(folder, "linearization.csv"))
           if r["material"] == "50kPa" and r["reference"].startswith("fem_linear")
           and r["method"] == "route2_modal"]
    force = [float(r["first_force_error"]) for r in lin]
    deformation = [float(r["first_deformation_error"]) for r in lin]
    return (f"50 kPa, first contact: route 2 (every mode, every frame force) against the "
            f"body-frame linear FEM, force {span(force)}, deformation {span(deformation)}")


def reduced_step_cost_headline(folder):
    table = markdown_table(os.path.join(folder, "README.md"))
    kept = [r for r in table if "kept tangent (the default)" in r["model, method"]]
    return ("the reduced step with the tangent kept, by vertex against element by element: "
            + "; ".join(f"{r['model, method'].split(',')[0].strip('`')} {r['by vertex'].split(';')[0]} "
                        f"against {r['element by element'].split(';')[0]}" for r in kept))


def reduced_step_rate_headline(folder):
    def p50(model, commit):
        values = []
        for run in sorted(glob.glob(os.path.join(folder, "play_ab", f"{model}_{commit}_*", "summary.csv"))):
            values += [float(r["deformation_step_p50_us"]) / 1000 for r in rows(run)]
        return span(values, lambda x: f"{x:.2f} ms")
    return ("`irdm play`, the accurate reduced model (r = 222): deformation step p50 "
            f"{p50('cat_top_r222', '6f43997')} (goal 1 ms) against {p50('cat_top_r222', '780b41c')} before "
            "the kept factorization and the rows in float")


def reduced_step_kernels_headline(folder):
    def p99(variant):
        values = []
        for run in sorted(glob.glob(os.path.join(folder, "play_ab", f"{variant}_[0-9]", "summary.csv"))):
            values += [float(r["deformation_step_p99_us"]) / 1000 for r in rows(run)]
        within = sum(v <= 1 for v in values)
        return f"{span(values, lambda x: f'{x:.2f} ms')} ({within} of {len(values)} runs within 1 ms)"
    return ("`irdm play`, r = 222 within the top presses' goals: deformation step p99 "
            f"{p99('cat_top_r222_c05_new_tol1e-6')} (696-element cubature, stop 1e-6), "
            f"{p99('cat_top_r222_new')} (997 elements), against {p99('cat_top_r222_old')} before the kernels")


def reduced_tangent_steps_headline(folder):
    def making(variant):
        made, runs = [], 0
        for run in sorted(glob.glob(os.path.join(folder, "play", f"cat_top_r222_tol1e-8_{variant}_[0-9]",
                                                 "deformation.csv"))):
            runs += 1
            made += [float(r["deformation_step_us"]) / 1000 for r in rows(run)[1:] if float(r["tangents_made"]) > 0]
        return f"{len(made)} in {runs} runs" + (f", {span(made, lambda x: f'{x:.1f} ms')}" if made else "")
    lag = {int(float(r["lag_steps"])): float(r["force_error"])
           for r in rows(os.path.join(folder, "lag", "cat_top_r222_tol1e-8", "lag.csv"))}
    return ("`irdm play`, r = 222 (stop 1e-8), steps making a tangent after the first: "
            f"{making('steps0')} with it made in the step, {making('steps8')} made over 8 steps; "
            f"the two loops' split with its force loop 1 step behind {100 * lag[1]:.2g} %, "
            f"2 steps {100 * lag[2]:.0f} % from the coupled solution")


def reduced_lag_headline(folder):
    def errors(variant):
        return {int(float(r["lag_steps"])): float(r["force_error"])
                for r in rows(os.path.join(folder, variant, "lag.csv"))}
    runs = [errors(v) for v in ("cat_top_r222_tol1e-8", "cat_top_r222_tol1e-6", "cat_top_r222_c05_tol1e-6")]
    def at(lag):
        return span([100 * e[lag] for e in runs], lambda x: f"{x:.2g} %")
    return ("the two loops' split with its force loop behind for the whole run, answering the "
            f"latest window's force: 1 step {at(1)}, 2 steps {at(2)}, 3 steps {at(3)} from the "
            "coupled solution (r = 222, stops 1e-8 and 1e-6, two cubatures)")


def free_step_headline(folder):
    def first_force(step, method):
        path = os.path.join(folder, "check", f"tau_{step}", "linearization.csv")
        for r in rows(path):
            if (r["case"] == "drop_2cm" and r["method"] == method
                    and r["reference"] == "fem_linear_body_frame"):
                return pct(float(r["first_force_error"]))
        return "-"
    steps = ["2ms", "0.5ms", "0.125ms"]
    method = " / ".join(first_force(t, "route2_modal") for t in steps)
    own = " / ".join(first_force(t, "fem_linear_body_frame_half_step") for t in steps)
    return (f"2 cm drop, first contact, floor force at 2 / 0.5 / 0.125 ms: route 2 against the "
            f"body-frame linear FEM {method}; that FEM against itself at half the step {own}")


def truth_convergence_headline(folder):
    def against(run, method):
        for r in rows(os.path.join(folder, run, "linearization.csv")):
            if r["case"] == "drop_2cm" and r["method"] == method and r["reference"].startswith(
                    "fem_neo_hookean_p1_"):
                return (f"{pct(float(r['first_force_error']))} / "
                        f"{pct(float(r['first_impulse_error']))} / "
                        f"{pct(float(r['first_deformation_error']))}")
        return "-"
    return ("50 kPa 2 cm drop, first contact, force / impulse / deformation against the truth on "
            f"cat_lc3.4mm: the truth on cat_fine {against('drop_2ms', 'fem_neo_hookean_p1_cat_fine')}, "
            f"on cat_xfine {against('drop_2ms', 'fem_neo_hookean_p1_cat_xfine')}, on the P1 cat "
            f"{against('drop_2ms', 'fem_neo_hookean')}")


def nonlinear_headline(folder):
    limits = [r for r in rows(os.path.join(folder, "limits.csv"))
              if r["truth"] == "fem_neo_hookean_p1" and r["measure"] == "shape"
              and r["method"] in ("vertex_contact_modal", "route2_modal")]
    parts = [f"{r['family']} {r['material']} {r['limit_5pct']}"
             for r in limits if r["family"] in ("press_side", "press_top", "free_impact")]
    return ("load where linear IRDM passes 5 % in shape (P1 truth): " + "; ".join(parts)
            if parts else "no limits")


def converged_headline(folder):
    data = rows(os.path.join(folder, "converged.csv"))
    method = [float(r["method_force_error"]) for r in data if r["discretization"] == "converged"]
    coarse = [float(r["fem_vs_converged_force_error"]) for r in data
              if r["discretization"] == "coarse"]
    return (f"method error on the converged cat {span(method)} in force; the coarse cat's FEM "
            f"against the converged {span(coarse)}")


def convergence_headline(folder):
    data = [r for r in rows(os.path.join(folder, "convergence.csv")) if r["fe_degree"] == "1"]
    first, last = data[0], max(data, key=lambda r: int(r["free_dofs"]))
    return (f"probe stiffness (2 cm radius) {float(first['stiffness_radius_N_m']):.1f} N/m on the "
            f"P1 cat, {float(last['stiffness_radius_N_m']):.1f} N/m at {last['free_dofs']} DoFs")


def verification_headline(folder):
    # The summary table's last cell (its criteria may hold a "|").
    results = []
    with open(os.path.join(folder, "report.md")) as fh:
        for line in fh:
            if line.startswith("|"):
                results.append(line.rstrip().rstrip("|").split("|")[-1].strip())
            elif results:
                break
    results = [r for r in results if r in ("pass", "fail")]
    return f"{results.count('pass')} of {len(results)} checks pass"


def play_headline(folder):
    data = [r for r in rows(os.path.join(folder, "study.csv")) if r["rate_hz"] == "1000"]
    step = [float(r["force_step_p99_us"]) for r in data]
    surface = [float(r["surface_update_p99_us"]) for r in data]
    us = lambda x: f"{x:.1f} us"  # noqa: E731
    return (f"at 1 kHz over {len(data)} runs: force step p99 {span(step, us)}, surface update "
            f"p99 {span(surface, us)}")


def scaling_headline(folder):
    data = rows(os.path.join(folder, "scaling.csv"))
    big = max(data, key=lambda r: int(r["free_dofs"]))
    return (f"largest model: {big['free_dofs']} free DoFs ({big['route']} route) in "
            f"{float(big['seconds_total']):.0f} s, {big['peak_rss_MB']} MB peak")


def calculix_headline(folder):
    table = markdown_table(os.path.join(folder, "README.md"))
    same = [r["H"] for r in table if r["model"] == "CalculiX" and "CalculiX's mass" in r["reference"]]
    mass = [r["H"] for r in table if r["model"] == "CalculiX" and "consistent" in r["reference"]]
    return (f"CalculiX's model against ours with its mass rule: H {' and '.join(same)}; "
            f"against ours with the consistent mass: H {' and '.join(mass)} (the mass rule)")


def sizing_headline(folder):
    table = markdown_table(os.path.join(folder, "README.md"))
    return (f"the press's closed loop with the lowest {table[0]['lowest modes']} to "
            f"{table[-1]['lowest modes']} modes (and residual modes): force {table[0]['force']} "
            f"to {table[-1]['force']} off the every-mode model")


def identification_headline(folder):
    table = markdown_table(os.path.join(folder, "README.md"))
    noisy = [r for r in table if r["noise"] == "1e-3"]
    return (f"ERA from H with noise of 1e-3 of its peak, 5 seeds: force {noisy[0]['force']} "
            f"under a rigid probe, {noisy[1]['force']} through a virtual coupling (passive)")


def benchmarks_headline(folder):
    table = markdown_table(os.path.join(folder, "benchmarks.md"))
    return f"{len(table)} runtime kernels timed, with their ratios to the direct convolution"


# (title, report, picture, headline, the code it measures: git pathspecs)
RUNTIME = ["irdm", "common"]
POINT = RUNTIME + ["reference_fem", "validation/src/point_*", "validation/src/compression_study*",
                   "validation/src/scene_runs*", "validation/src/metrics.h",
                   "validation/templates/scene.md", "validation/templates/validation.md",
                   "validation/templates/coupling_sweep.md"]
PLANES = RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/virtual_dof*",
                    "validation/src/plane_*", "validation/src/scene_runs*",
                    "validation/src/metrics.h", "validation/templates/planes.md"]
STUDIES = [
    ("Point probes: IRDM against the FEM (main job)", "quick/validation.md", "quick/press/force.png",
     point_headline, POINT),
    ("Point probes: IRDM against the FEM (full study)", "validation.md", "press/force.png",
     point_headline, POINT),
    ("Point probes with every compressor, ERA included (press, squeeze, tap, trace)",
     "era/validation.md", "era/press/speed_accuracy.png", point_headline, POINT),
    ("Plane contact against the nonlinear FEM (main job)", "quick/planes/planes.md",
     "quick/planes/planes.png", planes_headline,
     PLANES),
    ("Plane contact against the nonlinear FEM (full study)", "planes/planes.md",
     "planes/planes.png", planes_headline,
     PLANES),
    ("Reduced nonlinear models: two walls at once and a sliding wall", "reduced/planes/planes.md",
     "reduced/planes/planes.png", reduced_planes_headline,
     PLANES + ["irdm/src/reduced_nonlinear.cc", "irdm/src/cubature.cc",
               "reference_fem/src/reduced*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models: the side presses with a model of the side's reach",
     "reduced/side/nonlinear/nonlinear.md", "reduced/side/nonlinear/map_p1.png", reduced_map_headline,
     PLANES + ["irdm/src/reduced_nonlinear.cc", "irdm/src/cubature.cc", "reference_fem/src/reduced*",
               "validation/src/nonlinear_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models: the cubature trained on FEM snapshots (top presses)",
     "reduced/cubature/nonlinear/nonlinear.md", "reduced/cubature/nonlinear/speed_accuracy.png",
     reduced_map_headline,
     PLANES + ["irdm/src/reduced_nonlinear.cc", "irdm/src/cubature.cc", "reference_fem/src/reduced*",
               "validation/src/nonlinear_*", "scripts/reduced_report.sh"]),
    ("The reduced nonlinear step by vertex: its cost, and what 1 ms would need",
     "reduced/step_cost/README.md", None, reduced_step_cost_headline,
     RUNTIME + ["benchmarks/reduced_kernels.cc", "apps/play_reduced.cc"]),
    ("The reduced step at the force loop's rate: the kept factorization and U's rows in float",
     "reduced/step_rate/README.md", None, reduced_step_rate_headline,
     RUNTIME + ["benchmarks/reduced_kernels.cc", "apps/play_reduced.cc"]),
    ("The reduced step's kernels: the tangent's products, one product a residual, four elements at once",
     "reduced/step_kernels/README.md", None, reduced_step_kernels_headline,
     RUNTIME + ["benchmarks/reduced_kernels.cc", "apps/play_reduced.cc"]),
    ("The reduced step's tangent made over steps, and how much lag the two loops hold",
     "reduced/tangent_steps/README.md", None, reduced_tangent_steps_headline,
     RUNTIME + ["benchmarks/reduced_kernels.cc", "apps/play_reduced.cc"]),
    ("The two loops behind: the force loop answers for the force its state does not hold",
     "reduced/lag/README.md", None, reduced_lag_headline,
     RUNTIME + ["apps/play_reduced.cc"]),
    ("Reduced nonlinear models of the free cat (50 kPa)", "reduced/free/report.md",
     None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa) in a floating frame, with the uniform strain fields",
     "reduced/free_frame/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa): the floating frame beside one frame",
     "reduced/free_one_frame/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa): 10 s of rolling",
     "reduced/free_roll/report.md", "reduced/free_roll/stability.png", reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*"]),
    ("Reduced nonlinear models of the free cat (50 kPa): 60 s of rolling",
     "reduced/free_roll60/report.md", "reduced/free_roll60/stability.png", reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*"]),
    ("Reduced nonlinear models of the free cat (50 kPa) with inputs covering the contact patch: tilted drop, wall throw",
     "reduced/free_inputs/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa) with inputs covering the contact patch: drops and roll",
     "reduced/free_inputs_drops/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa) with inputs covering the contact patch, with a cubature",
     "reduced/free_inputs_cubature/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa) with a cubature: the forces' true torques beside the projected ones",
     "reduced/free_true_torques/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (50 kPa): 60 s of rolling with the true torques",
     "reduced/free_roll60_true/report.md", "reduced/free_roll60_true/stability.png", reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (2 kPa) in the floating frame, with a cubature: the 5 cm drop",
     "reduced/free_2kPa_frame/report.md", None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*", "scripts/reduced_report.sh"]),
    ("Reduced nonlinear models of the free cat (2 kPa)", "reduced/free_2kPa/free/report.md",
     None, reduced_free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/reduced*",
                "validation/src/free_body_*"]),
    ("Free bodies against the nonlinear FEM", "free/report.md", "free/impact.png", free_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/impulse_response*",
                "validation/src/free_body_*", "validation/src/metrics.h",
                "validation/templates/free.md"]),
    ("Free bodies with every frame force (50 kPa)", "free-frame/report.md", "free-frame/impact.png",
     free_frame_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "reference_fem/src/impulse_response*",
                "validation/src/free_body_*", "validation/src/metrics.h",
                "validation/templates/free.md"]),
    ("Free bodies: the time step against what it resolves (50 kPa)", "free-step/README.md", None,
     free_step_headline,
     RUNTIME + ["reference_fem/src/nonlinear*", "validation/src/free_body_*",
                "validation/step_study.py"]),
    ("Where each method holds, against the size of the load (main job: grounded, 5 cases)",
     "quick/nonlinear/nonlinear.md", "quick/nonlinear/map_p1.png", nonlinear_headline,
     PLANES + ["validation/src/nonlinear_*", "validation/templates/nonlinear.md"]),
    ("Where each method holds, against the size of the load", "nonlinear/nonlinear.md",
     "nonlinear/map_p1.png", nonlinear_headline,
     PLANES + ["validation/src/free_body_*", "validation/src/nonlinear_*",
               "validation/templates/nonlinear.md", "validation/templates/free.md"]),
    ("Is the nonlinear truth converged? Three finer meshes of the cat", "nonlinear/mesh_convergence/README.md",
     None, truth_convergence_headline,
     ["reference_fem/src/nonlinear*", "validation/src/free_body_*", "validation/src/surface_transfer.h",
      "meshes"]),
    ("Method and discretization error on the converged cat", "converged/report.md",
     "converged/converged.png", converged_headline,
     RUNTIME + ["reference_fem", "validation/src/converged_validation.cc",
                "validation/templates/converged.md"]),
    ("Mesh convergence", "convergence/convergence.md", "convergence/convergence.png",
     convergence_headline, ["reference_fem", "meshes", "scripts/convergence.sh"]),
    ("Reference FEM against theory (main job)", "quick/fem-verification/report.md",
     "quick/fem-verification/hertz.png", verification_headline,
     ["reference_fem", "validation/src/fem_verification.cc"]),
    ("Reference FEM against theory (full study)", "fem-verification/report.md",
     "fem-verification/hertz.png", verification_headline,
     ["reference_fem", "validation/src/fem_verification.cc"]),
    ("Two loops in real time (irdm play)", "play/study.md", None, play_headline,
     RUNTIME + ["apps/play.cc", "apps/templates/play.md", "scripts/play_study.sh"]),
    ("Precompute cost against DoFs", "scaling/scaling.md", "scaling/scaling.png",
     scaling_headline, ["reference_fem", "common", "scripts/scaling.sh"]),
    ("A second FEM as a source of models: CalculiX against ours", "calculix/README.md", None,
     calculix_headline, ["reference_fem", "irdm/src/response_exchange.cc",
                         "validation/src/model_sizing.cc"]),
    ("A model no larger than the scene needs: the precompute sized by a tolerance",
     "sizing/README.md", None, sizing_headline,
     ["reference_fem/src/impulse_response.cc", "reference_fem/src/sparse_modes.cc",
      "validation/src/model_sizing.cc"]),
    ("Identification from noisy responses; passivity on a virtual coupling",
     "identification/README.md", None, identification_headline,
     ["irdm/src/state_space_model.cc", "irdm/src/balanced_truncation.cc",
      "irdm/src/state_space_interaction.cc", "apps/commands/compress.cc"]),
    ("Runtime kernels (Google Benchmark)", "quick/benchmarks.md", None, benchmarks_headline,
     RUNTIME + ["benchmarks"]),
]

STAMP = re.compile(r"Made on (\d{4}-\d\d-\d\d)[^.]* at (?:commit ([0-9a-f]{7,40})(\+changes)?|"
                   r"an unknown commit)")


def made(report):
    """(date, commit, how we know): the report's own stamp, else the commit that added it."""
    with open(report) as fh:
        m = STAMP.search(fh.read(4000))
    if m and m.group(2):
        return m.group(1), m.group(2), "+changes" if m.group(3) else ""
    last = git("log", "-1", "--format=%cs %h", "--", report)
    if last:
        date, commit = last.split()
        return date, commit, "committed"
    return None, None, "not committed, not stamped"


def staleness(commit, paths):
    if not commit:
        return ""
    later = git("log", "--format=%h", f"{commit}..HEAD", "--", *paths)
    if later is None:
        return "(its commit is not in this history)"
    n = len(later.split())
    return f"**made before {n} later change{'s' if n > 1 else ''} to its code**" if n else ""


def main():
    reports = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "reports")
    lines = ["# Reports", "",
             "Every study in one line: its headline figure (from the report's own data), its "
             "picture, and when and at which commit its report was made. \"committed\": the "
             "report states no commit of its own (made before reports were stamped), so the "
             "commit that added it stands in. A report made before a later commit changed the "
             "code it measures is flagged; rerun its command (in the report) to refresh it. "
             "Written by `validation/reports_index.py` (`scripts/main.sh`).", "",
             "| study | headline | picture | made | |", "|---|---|---|---|---|"]
    for title, report, picture, headline, paths in STUDIES:
        path = os.path.join(reports, report)
        if not os.path.exists(path):
            lines.append(f"| {title} | not made yet | | | |")
            continue
        try:
            figure = headline(os.path.dirname(path))
        except (OSError, KeyError, ValueError, IndexError) as e:
            figure = f"(headline not read: {type(e).__name__})"
        date, commit, how = made(path)
        when = f"{date}, {commit}" + (f" ({how})" if how else "") if commit else how
        pic = f"[png]({picture})" if picture and os.path.exists(os.path.join(reports, picture)) else ""
        lines.append(f"| [{title}]({report}) | {figure} | {pic} | {when} | "
                     f"{staleness(commit, paths)} |")
    write_text(os.path.join(reports, "README.md"), "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
