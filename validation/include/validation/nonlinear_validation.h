#pragma once
// Where each method holds (issue 49, part 3): every method's error against the nonlinear truth
// as the load grows, on one page. The grounded cat pressed at the top, side and between the
// dome's directions from 0.5 to 20 mm and hit at the side at growing speeds (the plane study's
// cases and runner), and the free cat hitting the floor at growing speeds and dropped from
// growing heights, at both materials (the free-body study's cases and runner). Each row is
// scored against the P2 truth (P2 elements on the same mesh) where it ran on that case and the
// P1 truth elsewhere, and says which. Writes reports/nonlinear/ (nonlinear.csv, against_p1.csv,
// limits.csv, nonlinear.md, map.png, speed_accuracy.png).
#include <validation/free_body_validation.h>
#include <validation/plane_validation.h>

#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct NonlinearMapOptions
  {
    std::string report_dir = "reports";
    // Which scene families run: "planes" (the grounded cat) and "free" (the free cat). The
    // rows of a family not run are kept from an existing DIR/nonlinear/nonlinear.csv, so each
    // family is reproduced by its own command; none: the report and charts again from the CSV.
    std::vector<std::string> families = {"planes", "free"};
    // Keep also the earlier rows of the families run, of every case and material this run does
    // not make (a run that adds a method or a case to part of the map replaces only the rows
    // of the cases and materials it ran; its command is listed beside the earlier ones).
    bool keep_rows = false;
    // The grounded cat: the plane study's models, materials and runner (its sweep, perturbation
    // and plate parts are not run here), on these sweeps.
    PlaneValidationOptions   planes;
    std::vector<std::string> press_directions = {"top", "side", "between"};
    std::vector<double>      press_depths     = {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02}; // m
    std::vector<double>      impact_speeds    = {0.05, 0.1, 0.2, 0.5, 1.0};                // m/s
    // The free cat: the free-body study's models and runner, on its impact study (these
    // speeds, m/s, gravity off) and its drops.
    FreeBodyValidationOptions free;
    std::vector<double>       free_impact_speeds = {0.05, 0.1, 0.2, 0.4, 0.626, 0.99};
    std::vector<std::string>  drops              = {"drop_2cm", "drop_5cm", "drop_10cm"};
    std::string plot_script; // python script for the charts; "" skips them
    std::string command;     // this run's command line, which the report says reproduces it
  };

  void
  run_nonlinear_validation(const NonlinearMapOptions &options, std::ostream &log);
} // namespace irdm::validation
