// mrd-structure — the three-story structure of Dyke, Spencer, Sain & Carlson (1996) with MR
// dampers at the stories --dampers names (by default one, ground to first floor): modal check,
// off-line LQG design of the clipped-optimal law, and the in-process El Centro study
// (docs/structure.md).
#include <fcntl.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "mrd/common/cli_checks.hpp"
#include "mrd/common/write_atomically.hpp"
#include "mrd/structure/design.hpp"
#include "mrd/structure/reference.hpp"
#include "mrd/structure/study.hpp"

namespace {

using mrd::structure::Case;

using mrd::WriteAtomically;

void AddDesignOptions(CLI::App* cmd, mrd::structure::DesignOptions* d) {
  cmd->add_option("--period", d->period_s, "Control period T [s]")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(1e-4, 0.05));
  cmd->add_option("--q-displacement", d->q_displacement,
                  "LQR weight on each floor displacement [1/m^2]")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.0, 1e15));
  cmd->add_option("--q-drift", d->q_drift, "LQR weight on each inter-story drift [1/m^2]")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.0, 1e15));
  cmd->add_option("--r-force", d->r_force, "LQR weight on the damper force [1/N^2]")
      ->capture_default_str()
      ->check(mrd::cli::Finite);
  cmd->add_option("--noise-ratio", d->noise_ratio,
                  "Ground-acceleration / measurement-noise PSD ratio")
      ->capture_default_str()
      ->check(mrd::cli::Finite);
  cmd->add_option("--v-max", d->v_max, "Clipped rule's (and passive-on) voltage [V]")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.01, 24.0));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "mrd-structure: three-story structure with MR dampers (Dyke et al. 1996; one at the "
      "first story by default): modes, clipped-optimal design, El Centro study"};
  app.require_subcommand(1);
  mrd::structure::DesignOptions design;
  mrd::structure::StudyOptions study;

  auto* modes = app.add_subcommand("modes", "Modal frequencies and damping of the bare frame");
  auto* design_cmd = app.add_subcommand(
      "design", "Discrete LQG design of the clipped-optimal law; prints the gains as TOML");
  std::string design_out;
  std::string stories = "1";
  const char* kDampersHelp =
      "Stories with a damper, comma-separated (1 = ground to floor 1, ..., 3), e.g. 1,2";
  AddDesignOptions(design_cmd, &design);
  design_cmd->add_option("--dampers", stories, kDampersHelp)->capture_default_str();
  design_cmd->add_option("--out", design_out, "Write the gains TOML here (atomically)");

  auto* study_cmd = app.add_subcommand(
      "study",
      "Uncontrolled, passive-off, passive-on and clipped-optimal under the record: "
      "peak and RMS response table");
  std::string record_path = MRD_STRUCTURE_RECORD;
  std::string preset = "spencer1997";
  std::string study_out;
  AddDesignOptions(study_cmd, &study.design);
  study_cmd->add_option("--dampers", stories, kDampersHelp)->capture_default_str();
  study_cmd->add_option("--record", record_path, "Ground motion CSV (t_s,ag_g)")
      ->capture_default_str();
  study_cmd->add_option("--time-scale", study.time_scale, "Record played this many times faster")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.01, 100.0));
  study_cmd->add_option("--amplitude", study.amplitude, "Factor on the record's acceleration")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.0, 100.0));
  study_cmd->add_option("--substeps", study.substeps, "Plant RK4 steps per control period")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(1, 1000));
  study_cmd->add_option("--tail", study.tail_s, "Free vibration after the record [s]")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.0, 600.0));
  study_cmd->add_option("--damper", preset, "Damper preset: spencer1997 (Dyke 1996) or paper")
      ->capture_default_str();
  study_cmd->add_option("--out", study_out, "Also write the table here (atomically)");
  std::string reference_path;
  double tolerance = 20.0;
  study_cmd->add_option("--reference", reference_path,
                        "Published peak responses to compare with: CSV with the header "
                        "case,x1,x2,x3,d1,d2,d3,xa1,xa2,xa3,f (docs/structure.md); exit 3 "
                        "when a cell differs by more than --tolerance or clipped-optimal "
                        "changes a peak the other way");
  study_cmd->add_option("--tolerance", tolerance, "Allowed difference from --reference [%]")
      ->capture_default_str()
      ->check(mrd::cli::FiniteRange(0.0, 1e6));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  mrd::ShearFrameParams frame;
  std::string error;
  if (!mrd::structure::ParseDamperStories(stories, &frame, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }

  if (*modes) {
    const auto m = mrd::structure::FrameModes(frame);
    for (std::size_t i = 0; i < 3; ++i) {
      std::printf("mode %zu: %.3f Hz, damping %.4f\n", i + 1, m.frequency_hz[i],
                  m.damping_ratio[i]);
    }
    return 0;
  }
  if (*design_cmd) {
    mrd::firmware::ClippedOptimalGains gains;
    if (!mrd::structure::DesignClippedOptimal(frame, design, &gains, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 2;
    }
    const std::string toml = mrd::structure::GainsToml(gains, design);
    if (!design_out.empty()) {
      if (!WriteAtomically(design_out, toml, &error)) {
        std::fprintf(stderr, "error: %s\n", error.c_str());
        return 1;
      }
    } else {
      std::fputs(toml.c_str(), stdout);
    }
    return 0;
  }
  // study
  mrd::SpencerParams damper;
  if (!mrd::SpencerParams::FromPreset(preset, &damper)) {
    std::fprintf(stderr, "error: --damper: unknown preset '%s' (spencer1997, paper)\n",
                 preset.c_str());
    return 2;
  }
  mrd::GroundRecord record;
  if (!mrd::LoadGroundRecord(record_path, &record, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }
  mrd::structure::Reference reference;
  if (!reference_path.empty() &&
      !mrd::structure::LoadReference(reference_path, &reference, &error)) {
    std::fprintf(stderr, "error: --reference: %s\n", error.c_str());
    return 2;
  }
  mrd::firmware::ClippedOptimalGains gains;
  std::fprintf(stderr, "designing the clipped-optimal law ...\n");
  if (!mrd::structure::DesignClippedOptimal(frame, study.design, &gains, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 2;
  }
  std::vector<mrd::structure::Response> rows;
  for (Case c : {Case::kUncontrolled, Case::kPassiveOff, Case::kPassiveOn, Case::kClippedOptimal}) {
    std::fprintf(stderr, "running %s ...\n", mrd::structure::CaseName(c));
    mrd::structure::Response r;
    if (!mrd::structure::RunCase(c, record, frame, damper, gains, study, &r, &error)) {
      std::fprintf(stderr, "error: %s\n", error.c_str());
      return 2;
    }
    rows.push_back(r);
  }
  std::string table = mrd::structure::ResponseTable(rows);
  bool matches = true;
  if (!reference_path.empty()) {
    const mrd::structure::ReferenceCheck check =
        mrd::structure::CompareWithReference(rows, reference, tolerance);
    table += "\n" + check.table;
    matches = check.outside == 0 && check.changes_matched == check.changes;
  }
  std::fputs(table.c_str(), stdout);
  if (!study_out.empty() && !WriteAtomically(study_out, table, &error)) {
    std::fprintf(stderr, "error: %s\n", error.c_str());
    return 1;
  }
  return matches ? 0 : 3;
}
