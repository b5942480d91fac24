// irdm play: the two asynchronous loops in real time from a recorded device trajectory.
#include "../command.h"

#include "../play.h"

#include <iostream>
#include <memory>

namespace irdm::cli
{
  Command
  add_play(CLI::App &app)
  {
    auto po = std::make_shared<irdm::play::PlayOptions>();
    auto *play = app.add_subcommand("play", "the two asynchronous loops in real time from a recorded device trajectory");
    play->footer("Runs a force thread (contact solve and force history) and a deformation thread (full surface update at --display-hz) "
      "in real time, sharing the body's state through a lock-free triple buffer (seed 001 "
      "section 4.2). The device (a point probe on one model vertex) moves that vertex by its own "
      "motion since it crossed the rest surface, while it is behind it. --force-modes K: the "
      "lowest K modes carry the force history, the rest respond quasi-statically (faster "
      "step; play.md states the force error against every mode). One model step per force tick: "
      "--rate-hz other than 1 / time step plays the trajectory faster or slower than real "
      "time. Writes DIR/forces.csv, histogram.csv, play.md (latency and jitter percentiles, "
      "missed deadlines, force error against the exact model) and surface/surface.pvd (VTU "
      "frames for ParaView). Exit 3 if more than 0.1 % of deadlines were missed. Example "
      "trajectories: examples/trajectories/. With a reduced nonlinear model (irdm precompute --reduced) "
      "the loops are the seed's split on that body: the force loop solves a virtual coupling "
      "(--coupling-stiffness required) against the probed point's local compliance, the "
      "deformation loop takes the Newton step; writes DIR/forces.csv, deformation.csv, "
      "summary.csv and play.md (docs/reduced-model.md).");
    play->add_option("model", po->model, "impulse-response model (HDF5, with its modes), or a reduced nonlinear model")
      ->required()
      ->check(CLI::ExistingFile);
    play->add_option("--trajectory", po->trajectory, "device CSV: time_s,x_m,y_m,z_m (model frame, m)")
      ->required()
      ->check(CLI::ExistingFile);
    play->add_option("--rate-hz", po->rate_hz, "force loop rate (default: 1 / the model's time step)")
      ->check(CLI::Range(1.0, 100000.0));
    play->add_option("--display-hz", po->display_hz, "deformation loop rate")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 10000.0));
    play->add_option("--surface-modes", po->surface_modes, "modes of the surface update")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000000u));
    play->add_option("--force-modes", po->force_modes,
                     "modes in the force loop's history (default: all, the exact model; fewer: "
                     "faster, the rest quasi-static)")
      ->check(CLI::Range(1u, 1000000u));
    play->add_option("--force-tolerance", po->force_tolerance,
                     "choose --force-modes before the run: the fewest of 25, 50, 100, ... whose "
                     "force over this trajectory, replayed offline, is within this fraction "
                     "(relative L2) of every mode's")
      ->check(CLI::Range(1e-12, 0.999))
      ->excludes("--force-modes");
    play->add_option("--vertex", po->vertex, "probed model vertex (default: the input vertex nearest the first sample)")
      ->check(CLI::Range(0L, 100000000L));
    play->add_option("--frames", po->max_frames, "VTU frames written, at most")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    play->add_option("--coupling-stiffness", po->coupling_stiffness,
                     "virtual coupling spring between device and vertex, N/m (with "
                     "--coupling-damping; both 0: the rigid probe)")
      ->check(CLI::Range(0.0, 1e12));
    play->add_option("--coupling-damping", po->coupling_damping,
                     "virtual coupling damper, N s/m")
      ->check(CLI::Range(0.0, 1e12));
    play->add_option("--newton-tolerance", po->newton_tolerance,
                     "a reduced nonlinear model's Newton stop: the residual within this fraction of "
                     "its largest force")
      ->capture_default_str()
      ->check(CLI::Range(1e-14, 1e-2));
    play->add_option("--tangent-steps", po->tangent_steps,
                     "a reduced nonlinear model's tangent, where Newton asks for a new one, made over "
                     "this many deformation steps, a piece a step, instead of inside the step (0: "
                     "inside the step)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1000u));
    play->add_option("--lag-steps", po->lag_steps,
                     "a reduced nonlinear model: the offline check again with the force loop on the "
                     "state this many deformation steps old, each value a run (lag.csv)")
      ->check(CLI::Range(1u, 1000u));
    play->add_option("--out", po->out_dir, "output folder")->capture_default_str();
    play->add_flag("!--no-check", po->check, "skip the offline replay with the exact model");
    play->add_flag("!--no-pin", po->pin, "do not pin the threads to CPUs");
    play->add_option("--spin-us", po->spin_us,
                     "the force thread wakes this early and spins to each tick, us (default: "
                     "90 % of the period; 0: sleep to the tick)")
      ->check(CLI::Range(0.0, 1e6));
    play->add_option("--warm-us", po->warm_us,
                     "the deformation thread wakes this long before each frame and reads the "
                     "surface shapes into its cache until the frame (once, then a spin, with "
                     "--warm-once), us (0: it sleeps to the frame and the update streams the "
                     "shapes from memory)")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
    play->add_flag("!--no-warm-step", po->warm_step,
                   "the force thread does not read the step's data into its cache at the start "
                   "of its spin (ModalInteraction::warm_step)");
    play->add_flag("!--warm-once", po->keep_warm,
                   "each warm-up runs once at the start of its spin (default: it repeats until "
                   "the tick, so that what a long interruption evicted is read back)");
    play->add_flag("!--no-baseline", po->baseline,
                   "skip the baseline (the same force loop with no work, run first for as long: "
                   "the machine's own stalls)");
    play->add_flag("--quiet", po->quiet, "no progress");
    return {play, [po] { return irdm::play::run_play(*po, std::cout); }};
  }
} // namespace irdm::cli
