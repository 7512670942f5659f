#pragma once
// The `formfactor` subcommands: each file cmd_<name>.cpp defines add_<name>_command(), which
// registers the subcommand, its options and its callback on the main app. A new subcommand is a
// new file plus one line in main.cpp.

#include <CLI/CLI.hpp>

namespace formfactor::cli {

/// `formfactor compute SCENE -o OUT [...]`: the form-factor matrix of a scene.
void add_compute_command(CLI::App& app);
/// `formfactor point SCENE (--at X Y Z --normal NX NY NZ | --points FILE.csv) [-o OUT]`: F from
/// differential elements to every patch, with obstructions.
void add_point_command(CLI::App& app);
/// `formfactor info SCENE [--json]`: what a scene holds.
void add_info_command(CLI::App& app);
/// `formfactor run [SCENE]`: the main job, everything into out/.
void add_run_command(CLI::App& app);
/// `formfactor solve SCENE -o RESULT.csv [...]`: radiosity or thermal solution.
void add_solve_command(CLI::App& app);
/// `formfactor render SCENE --radiosity RESULT.csv -o image.png [...]`: pictures and meshes.
void add_render_command(CLI::App& app);
/// `formfactor inspect SCENE --patch I -o VIEW.png [...]`: what a point sees through the
/// hemicube or the hemiplane, as a picture.
void add_inspect_command(CLI::App& app);
/// `formfactor view SCENE [method options | --matrix F] [--radiosity B.csv | --thermal T.csv]
/// -o result.html`: the result page, one self-contained HTML file.
void add_view_command(CLI::App& app);

}  // namespace formfactor::cli
