#pragma once
// irdm play: the seed's two asynchronous loops (seed 001 section 4.2) in real time, driven by a
// recorded device trajectory. Uses only the runtime (irdm/, no deal.II).
#include <ostream>
#include <string>

namespace irdm::play
{
  struct PlayOptions
  {
    std::string model;      // impulse-response model with its modal realization
    std::string trajectory; // CSV: time_s,x_m,y_m,z_m (device tip, model frame, m)
    std::string out_dir = "play";
    double      rate_hz    = 0;   // force loop; 0: 1 / the model's time step (real time)
    double      display_hz = 100; // deformation loop
    unsigned    surface_modes = 100;
    unsigned    force_modes   = 0; // force-loop modes; 0: all (the exact model)
    // > 0: force_modes chosen before the run, the fewest of 25, 50, 100, ... whose force over
    // this trajectory, replayed offline, is within this fraction (relative L2) of every mode's.
    double      force_tolerance = 0;
    long        vertex        = -1; // probed output vertex; -1: nearest the first sample
    unsigned    max_frames    = 100; // VTU frames kept (evenly spaced over the run)
    bool        check         = true; // replay offline with every mode (the exact model)
    bool        pin           = true; // pin the force thread to the last CPU
    // The force thread sleeps until this long before each tick and then spins on the clock
    // (us; 0: it sleeps to the tick; negative: 90 % of the period). A haptic servo thread owns
    // its CPU: a vCPU that keeps running is not descheduled by its host between ticks, which
    // is where the late wake-ups of a sleeping loop come from (reports/play/README.md).
    double spin_us = -1;
    // The force thread reads the next step's data into its cache when it starts to spin
    // (ModalInteraction::warm_step): the step then finds it there.
    bool warm_step = true;
    // The deformation thread wakes this long before each frame and reads the surface shapes
    // into its cache (warm_surface) up to the frame (us; 0: it sleeps to the frame, no
    // warm-up). It stays busy rather than sleeps after the warm-up: a vCPU that halts can
    // resume on another host core, with the shapes no longer in its cache
    // (reports/play/README.md).
    double warm_us = 500;
    // Both warm-ups repeat until the tick (each pass read again before the work) rather than
    // run once at the start of the spin: a long interruption by the host evicts what one
    // warm-up read (reports/play/README.md). false: one pass, then the spin (--warm-once).
    bool keep_warm = true;
    bool        quiet         = false;
    bool        baseline      = true; // first the same loop with no work: the machine's stalls
    // Virtual coupling (contact::Coupling): the device pulls the probed vertex through a spring
    // (N/m) and damper (N s/m), unilateral on the coupled force. Both 0: the rigid probe.
    double coupling_stiffness = 0;
    double coupling_damping   = 0;
    // A reduced nonlinear model's Newton stop: the residual within this fraction of its
    // largest force (ReducedBodyOptions::tolerance).
    double newton_tolerance = 1e-8;
    // A reduced nonlinear model's tangent made over this many deformation steps where Newton
    // asks for a new one (ReducedBodyOptions::tangent_steps; 0: inside the step): the step that
    // asks then does not make a whole one.
    unsigned tangent_steps = 8;
    // A reduced nonlinear model's offline check again with the force loop working on the
    // state this many deformation steps old, each value a run (lag.csv): how much lag the
    // split holds.
    std::vector<unsigned> lag_steps;
  };

  /// Runs the two loops and writes DIR/forces.csv, histogram.csv, play.md and
  /// surface/surface.pvd with its VTU frames. Returns the exit status (0, or 3 if the loop
  /// missed more than 0.1 % of its deadlines). InputError on bad input.
  int
  run_play(const PlayOptions &options, std::ostream &out);

  /// run_play for a reduced nonlinear model (irdm precompute --reduced; apps/play_reduced.cc):
  /// the force loop on the probed point's local compliance, the deformation loop taking the
  /// Newton step; a virtual coupling (coupling_stiffness > 0) is required. Writes
  /// DIR/forces.csv, deformation.csv, summary.csv and play.md.
  int
  run_reduced_play(const PlayOptions &options, std::ostream &out);
} // namespace irdm::play
