// The `formfactor` command line: parses arguments, calls the library, and maps errors to one
// line on stderr and an exit code (0 success, 1 bad input, 2 bad usage or option, 3 internal
// error). SIGINT / SIGTERM stop the work cleanly (signals.h): one line, no output file, and the
// process then dies of that signal (exit status 130 / 143 in a shell).

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <new>
#include <string>

#include "commands.h"
#include "common.h"
#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/distributed/distributed.h"
#include "signals.h"

namespace {

/// Prints "formfactor: <message>" as a single line on stderr.
void print_error(const std::string& message) {
    std::string line = formfactor::cli::cli_text(message);
    for (char& c : line)
        if (c == '\n' || c == '\r') c = ' ';
    while (!line.empty() && line.back() == ' ') line.pop_back();
    std::fflush(stdout);
    fmt::print(stderr, "formfactor: {}\n", line);
}

// The command on rank 0 (the only rank without MPI).
int run_command(int argc, char** argv) {
    CLI::App app{"formfactor " FF_VERSION
                 " — radiative form factors (view factors) between the polygons of a 3D scene",
                 "formfactor"};
    app.set_version_flag("--version", "formfactor " FF_VERSION "\nLicence: MIT (the LICENSE file)");
    app.require_subcommand(1);
    app.footer(formfactor::cli::help_footer());

    formfactor::cli::add_compute_command(app);
    formfactor::cli::add_point_command(app);
    formfactor::cli::add_info_command(app);
    formfactor::cli::add_run_command(app);
    formfactor::cli::add_solve_command(app);
    formfactor::cli::add_render_command(app);
    formfactor::cli::add_inspect_command(app);
    formfactor::cli::add_view_command(app);

    if (argc <= 1) {
        std::fputs(app.help().c_str(), stdout);
        return 0;
    }
    if (argv[1][0] != '-') {
        std::string names;
        bool known = false;
        for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
            known = known || sub->get_name() == argv[1];
            names += (names.empty() ? "" : ", ") + sub->get_name();
        }
        if (!known) {
            print_error(fmt::format("unknown subcommand '{}' (use {})", argv[1], names));
            return 2;
        }
    }
    formfactor::cli::install_signal_handlers();
    try {
        app.parse(argc, argv);
        return 0;
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);
        print_error(e.what());
        return 2;
    } catch (const formfactor::Cancelled& e) {
        const int sig = formfactor::cli::received_signal();
        if (sig == 0) {
            print_error(e.what());
            return 1;
        }
        print_error(fmt::format("interrupted by {}: stopped, no output written",
                                formfactor::cli::signal_name(sig)));
        formfactor::distributed::finish();
        return formfactor::cli::die_of_signal(sig);
    } catch (const formfactor::OptionError& e) {
        // The library names option fields; the user typed flags.
        print_error(formfactor::cli::cli_flag(e.field()) + ": " + e.message());
        return 2;
    } catch (const formfactor::Error& e) {
        print_error(e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        // The estimate before the run (formfactor/matrix/memory.h) let it start: a part it does
        // not count grew too large. Still one clear line, not "internal error: std::bad_alloc".
        print_error(
            "out of memory: the run needed more memory than the machine could give (use fewer "
            "patches, or free memory)");
        return 1;
    } catch (const std::exception& e) {
        print_error(std::string("internal error: ") + e.what());
        return 3;
    } catch (...) {
        print_error("internal error: unknown exception");
        return 3;
    }
}

// Under mpirun (formfactor/distributed/distributed.h): ranks other than 0 compute the rows
// rank 0 hands them and print nothing; rank 0 runs the command and prints its one error line.
int run_other_rank() {
    formfactor::cli::install_signal_handlers();
    try {
        return formfactor::distributed::serve();
    } catch (const formfactor::Cancelled&) {
        const int sig = formfactor::cli::received_signal();
        return sig ? formfactor::cli::die_of_signal(sig) : 1;
    } catch (const std::exception& e) {
        print_error(
            fmt::format("rank {}: internal error: {}", formfactor::distributed::rank(), e.what()));
        return 3;
    }
}

}  // namespace

int main(int argc, char** argv) {
    formfactor::distributed::Session mpi(argc, argv);
    if (mpi.rank() > 0) return run_other_rank();
    const int code = run_command(argc, argv);
    formfactor::distributed::finish();
    return code;
}
