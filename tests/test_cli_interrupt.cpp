// Interrupts: SIGINT or SIGTERM during a long computation stops it promptly and leaves neither an
// output file nor a temporary file behind; the CLI says so in one line and dies of the signal.

#include <doctest/doctest.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "formfactor/core/atomic_file.h"
#include "formfactor/core/cancel.h"
#include "support/temp_dir.h"

using namespace formfactor;
using formfactor::testing::read_text;
using formfactor::testing::TempDir;

namespace {

struct Interrupted {
    int status = 0;            ///< waitpid status
    double seconds_after = 0;  ///< from the signal to the end of the process
    std::string err;
    std::vector<std::string> left;  ///< what the working directory holds afterwards
};

// Starts `formfactor args...` in `work`, its stdout and stderr in `capture`'s stdout.txt and
// stderr.txt, with `extra_env` added to this process's environment.
pid_t start(const TempDir& work, const TempDir& capture, const std::vector<std::string>& args,
            const std::vector<std::string>& extra_env = {}) {
    const std::string out = capture.file("stdout.txt"), err = capture.file("stderr.txt");
    std::vector<std::string> argv_s = {FF_CLI_PATH};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_s;
    for (char** e = environ; *e; ++e) env_s.emplace_back(*e);
    env_s.insert(env_s.end(), extra_env.begin(), extra_env.end());
    std::vector<char*> envp;
    for (std::string& e : env_s) envp.push_back(e.data());
    envp.push_back(nullptr);
    const std::string dir = work.path().string();

    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
        // The child: only async-signal-safe calls until exec.
        const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int in = ::open("/dev/null", O_RDONLY);
        if (o < 0 || e < 0 || in < 0 || ::chdir(dir.c_str()) != 0) ::_exit(126);
        ::dup2(o, 1);
        ::dup2(e, 2);
        ::dup2(in, 0);
        ::signal(SIGINT, SIG_DFL);
        ::signal(SIGTERM, SIG_DFL);
        ::execve(argv[0], argv.data(), envp.data());
        ::_exit(127);
    }
    return pid;
}

// Sends `sig` to the running process `pid` (started in `work`, stderr in `capture`), calls
// at_signal() right after, and waits for its end: its status, the time it took to end, its
// stderr and what `work` holds afterwards.
template <class AtSignal>
Interrupted signal_and_wait(pid_t pid, int sig, const TempDir& work, const TempDir& capture,
                            AtSignal&& at_signal) {
    int status = 0;
    // The process must still be running when the signal comes, else the test proves nothing.
    REQUIRE(::waitpid(pid, &status, WNOHANG) == 0);
    const auto sent = std::chrono::steady_clock::now();
    REQUIRE(::kill(pid, sig) == 0);
    at_signal();
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    Interrupted r;
    r.seconds_after =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
    r.status = status;
    r.err = read_text(capture.file("stderr.txt"));
    for (const auto& entry : std::filesystem::directory_iterator(work.path()))
        r.left.push_back(entry.path().filename().string());
    return r;
}

// Runs `formfactor args...` in `work` (stdout and stderr captured in `capture`), sends `sig`
// after `delay`, and waits for it to end.
Interrupted interrupt(const TempDir& work, const TempDir& capture,
                      const std::vector<std::string>& args, int sig,
                      std::chrono::milliseconds delay) {
    const pid_t pid = start(work, capture, args);
    std::this_thread::sleep_for(delay);
    return signal_and_wait(pid, sig, work, capture, [] {});
}

// The phase a run announced last on stderr (FORMFACTOR_TEST_PHASES), "" before the first.
std::string current_phase(const std::string& err) {
    const std::string marker = "formfactor: phase ";
    const std::size_t at = err.rfind(marker);
    if (at == std::string::npos) return "";
    const std::size_t end = err.find('\n', at);
    if (end == std::string::npos) return "";  // the line is still being written
    return err.substr(at + marker.size(), end - at - marker.size());
}

struct PhaseInterrupted : Interrupted {
    std::string phase_at_signal;  ///< the phase announced last when the signal went
};

// Runs `formfactor args...` in `work` with FORMFACTOR_TEST_PHASES set, waits until `phase` is the
// phase it announced last, lets the phase run for `into` and sends SIGTERM; waits for the end.
PhaseInterrupted interrupt_in_phase(const TempDir& work, const TempDir& capture,
                                    const std::vector<std::string>& args, const std::string& phase,
                                    std::chrono::milliseconds into) {
    const std::string err = capture.file("stderr.txt");
    const pid_t pid = start(work, capture, args, {"FORMFACTOR_TEST_PHASES=1"});
    int status = 0;
    // Generous: the phases before it may take long on a loaded machine.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(300);
    bool reached = false;
    while (std::chrono::steady_clock::now() < give_up) {
        // The phase announced last, not any time before: a phase that recurs (a block's
        // threshold between the rows of the next) may be over by the time it is read.
        if (current_phase(read_text(err)) == phase) {
            reached = true;
            break;
        }
        if (::waitpid(pid, &status, WNOHANG) == pid) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (!reached) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        FAIL("phase '" << phase << "' never announced; stderr: " << read_text(err));
    }
    std::this_thread::sleep_for(into);
    std::string at_signal;
    PhaseInterrupted r;
    static_cast<Interrupted&>(r) = signal_and_wait(
        pid, SIGTERM, work, capture, [&] { at_signal = current_phase(read_text(err)); });
    r.phase_at_signal = at_signal;
    return r;
}

std::string listing(const std::vector<std::string>& names) {
    std::ostringstream s;
    for (const std::string& n : names) s << n << " ";
    return s.str();
}

// A computation of ~30 s or more (720 patches × 10⁶ rays), so the signal always comes mid-way.
const std::vector<std::string> kLongCompute = {
    "compute",   "cornell", "--subdivide", "6",           "--method",  "mc-hemisphere",
    "--samples", "1000000", "--threads",   "2",           "-o",        "F.npy",
    "--stderr",  "SE.npy",  "--report",    "report.json", "--patches", "patches.csv"};

}  // namespace

TEST_CASE("cli interrupt: SIGINT during compute leaves no output and no temporary") {
    TempDir work, capture;
    const Interrupted r =
        interrupt(work, capture, kLongCompute, SIGINT, std::chrono::milliseconds(1500));
    INFO("stderr: " << r.err);
    CHECK(WIFSIGNALED(r.status));
    if (WIFSIGNALED(r.status)) CHECK(WTERMSIG(r.status) == SIGINT);
    CHECK(r.err == "formfactor: interrupted by SIGINT: stopped, no output written\n");
    INFO("left: " << listing(r.left));
    CHECK(r.left.empty());
    CHECK(r.seconds_after < 10.0);
}

TEST_CASE("cli interrupt: SIGTERM during solve leaves no output and no temporary") {
    TempDir work, capture;
    const Interrupted r =
        interrupt(work, capture,
                  {"solve", "cornell", "--subdivide", "6", "--method", "mc-hemisphere", "--samples",
                   "1000000", "--threads", "2", "-o", "B.csv", "--report", "report.json"},
                  SIGTERM, std::chrono::milliseconds(1500));
    INFO("stderr: " << r.err);
    CHECK(WIFSIGNALED(r.status));
    if (WIFSIGNALED(r.status)) CHECK(WTERMSIG(r.status) == SIGTERM);
    CHECK(r.err == "formfactor: interrupted by SIGTERM: stopped, no output written\n");
    INFO("left: " << listing(r.left));
    CHECK(r.left.empty());
    CHECK(r.seconds_after < 10.0);
}

TEST_CASE("cancellation: a request before the rename leaves neither file nor temporary") {
    TempDir dir;
    const std::string path = dir.file("F.csv");
    CancellationFlag& flag = process_cancellation();
    // The request arrives while the content is being written.
    CHECK_THROWS_AS(write_file_atomically(path,
                                          [&](std::ostream& out) {
                                              out << "0,1\n";
                                              flag.request();
                                          }),
                    Cancelled);
    CHECK(dir.entries() == 0);
    // A transaction staged before the request commits nothing.
    flag.reset();
    {
        OutputTransaction tx;
        tx.stage(dir.file("a.csv"), [](std::ostream& out) { out << "a\n"; });
        tx.stage(dir.file("b.csv"), [](std::ostream& out) { out << "b\n"; });
        flag.request();
        CHECK_THROWS_AS(tx.commit(), Cancelled);
    }
    CHECK(dir.entries() == 0);
    flag.reset();
    write_file_atomically(path, [](std::ostream& out) { out << "0,1\n"; });
    CHECK(dir.entries() == 1);
}

namespace {

// What every interrupted phase must show: the phase was running when the signal came, the run
// ended within a second (three on a loaded machine), died of the signal with its one line, and
// left nothing in the working directory.
void check_prompt_stop(const PhaseInterrupted& r, const std::string& phase) {
    INFO("stderr: " << r.err);
    MESSAGE("phase '" << phase << "': ended " << r.seconds_after << " s after SIGTERM");
    CHECK(r.phase_at_signal == phase);
    CHECK(WIFSIGNALED(r.status));
    if (WIFSIGNALED(r.status)) CHECK(WTERMSIG(r.status) == SIGTERM);
    CHECK(r.err.ends_with("formfactor: interrupted by SIGTERM: stopped, no output written\n"));
    INFO("left: " << listing(r.left));
    CHECK(r.left.empty());
    CHECK(r.seconds_after < 3.0);
}

// A dense 4,320-patch matrix: the rows take ~0.6 s, the diagnosis ~0.3 s, the text ~0.35 s.
const std::vector<std::string> kDenseText = {"compute",   "room-24", "--method",  "mc-hemisphere",
                                             "--samples", "100",     "--threads", "2",
                                             "-o",        "F.csv"};

}  // namespace

TEST_CASE("cli interrupt: the iterative solvers stop within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // Reflectance 0.999 in a closed room and a tight residual: thousands of sweeps, seconds.
    for (const std::string solver : {"jacobi", "gauss-seidel"}) {
        CAPTURE(solver);
        TempDir work, capture;
        std::string properties =
            "patch,reflectance_r,reflectance_g,reflectance_b,emission_r,"
            "emission_g,emission_b\n";
        for (int i = 0; i < 1536; ++i)
            properties += std::to_string(i) + ",0.999,0.999,0.999,1,1,1\n";
        formfactor::testing::write_text(capture.file("P.csv"), properties);
        const PhaseInterrupted r = interrupt_in_phase(
            work, capture,
            {"solve", "room-16", "--method", "mc-hemisphere", "--samples", "100", "--threads", "2",
             "--solver", solver, "--properties", capture.file("P.csv"), "--residual", "1e-15",
             "--max-iterations", "2000000000", "--allow-unconverged", "-o", "B.csv"},
            "solve", std::chrono::milliseconds(300));
        check_prompt_stop(r, "solve");
    }
}

TEST_CASE("cli interrupt: the dense diagnosis stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    TempDir work, capture;
    check_prompt_stop(
        interrupt_in_phase(work, capture, kDenseText, "diagnose", std::chrono::milliseconds(100)),
        "diagnose");
}

TEST_CASE("cli interrupt: writing a large text matrix stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // 7,680 patches: 59 M entries of text, about a second of writing on a quiet machine.
    TempDir work, capture;
    std::vector<std::string> args = kDenseText;
    args[1] = "room-32";
    check_prompt_stop(
        interrupt_in_phase(work, capture, args, "write", std::chrono::milliseconds(100)), "write");
}

TEST_CASE("cli interrupt: the direct (LU) solve stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // LU of 3,000 × 3,000 per colour: ten seconds and more.
    TempDir work, capture;
    check_prompt_stop(
        interrupt_in_phase(work, capture,
                           {"solve", "room-20", "--method", "mc-hemisphere", "--samples", "100",
                            "--threads", "2", "--solver", "direct", "-o", "B.csv"},
                           "solve", std::chrono::milliseconds(300)),
        "solve");
}

TEST_CASE("cli interrupt: the sparse diagnosis stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // 4,320 patches, ~4,000 entries a row: the diagnosis's reciprocity lookups take seconds.
    TempDir work, capture;
    check_prompt_stop(
        interrupt_in_phase(work, capture,
                           {"solve", "room-24", "--method", "hemicube", "--resolution", "64",
                            "--threads", "2", "--storage", "sparse", "-o", "B.csv"},
                           "diagnose", std::chrono::milliseconds(100)),
        "diagnose");
}

TEST_CASE("cli interrupt: the analytic classification stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // A 4,249-patch city: its largest pairs of surfaces are seconds of shaft tests each. Sparse
    // rows classify in blocks, each a sample of every size, the largest tasks first: 300 ms
    // into the first block its largest task is still running.
    TempDir work, capture;
    check_prompt_stop(interrupt_in_phase(work, capture,
                                         {"compute", "city-12", "--method", "analytic", "--threads",
                                          "2", "-o", "F.mtx"},
                                         "analytic classification", std::chrono::milliseconds(300)),
                      "analytic classification");
}

TEST_CASE("cli interrupt: thresholding sparse rows stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // 4,320 patches, ~4,000 entries a row from dense hemicube rows: the threshold into CSR takes
    // well under a second on a quiet machine, so the signal goes as soon as the phase begins.
    TempDir work, capture;
    check_prompt_stop(
        interrupt_in_phase(work, capture,
                           {"solve", "room-24", "--method", "hemicube", "--resolution", "64",
                            "--threads", "2", "--storage", "sparse", "-o", "B.csv"},
                           "threshold", std::chrono::milliseconds(0)),
        "threshold");
}

namespace {

// The analytic method on a 104,761-patch city, sparse rows: its setup (plane groups, merged
// blockers, closed solids) takes seconds, its classification minutes.
const std::vector<std::string> kLargeCityAnalytic = {"compute",   "city-60", "--method", "analytic",
                                                     "--threads", "2",       "-o",       "F.mtx"};

// A room of 1,536 patches around a box at a tight tolerance: the setup and the classification
// take a fraction of a second, the partly hidden pairs seconds.
std::vector<std::string> obstructed_room(const std::string& storage, const std::string& out) {
    return {"compute",     "room-16-obstruction",
            "--method",    "analytic",
            "--tolerance", "1e-7",
            "--storage",   storage,
            "--threads",   "2",
            "-o",          out};
}

}  // namespace

TEST_CASE("cli interrupt: the analytic setup of a large city stops within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    TempDir work, capture;
    check_prompt_stop(interrupt_in_phase(work, capture, kLargeCityAnalytic, "analytic setup",
                                         std::chrono::milliseconds(0)),
                      "analytic setup");
}

TEST_CASE(
    "cli interrupt: the analytic classification of a large city stops within a second of "
    "SIGTERM" *
    doctest::test_suite("slow")) {
    TempDir work, capture;
    check_prompt_stop(interrupt_in_phase(work, capture, kLargeCityAnalytic,
                                         "analytic classification", std::chrono::milliseconds(0)),
                      "analytic classification");
}

TEST_CASE(
    "cli interrupt: the analytic partly hidden pass (dense) stops within a second of SIGTERM" *
    doctest::test_suite("slow")) {
    TempDir work, capture;
    check_prompt_stop(
        interrupt_in_phase(work, capture, obstructed_room("dense", "F.npy"),
                           "analytic partly hidden pairs", std::chrono::milliseconds(0)),
        "analytic partly hidden pairs");
}

TEST_CASE(
    "cli interrupt: the analytic partly hidden pass (sparse rows) stops within a second of "
    "SIGTERM" *
    doctest::test_suite("slow")) {
    TempDir work, capture;
    check_prompt_stop(
        interrupt_in_phase(work, capture, obstructed_room("sparse", "F.mtx"),
                           "analytic partly hidden pairs", std::chrono::milliseconds(0)),
        "analytic partly hidden pairs");
}

TEST_CASE("cli interrupt: the analytic visible pairs of a city stop within a second of SIGTERM" *
          doctest::test_suite("slow")) {
    // A 1,905-patch city, sparse rows: 13 s of classification (on a loaded 2-core machine),
    // then the exact values of the pairs that see each other whole, tenths of a second.
    TempDir work, capture;
    check_prompt_stop(interrupt_in_phase(work, capture,
                                         {"compute", "city-8", "--method", "analytic",
                                          "--tolerance", "1e-9", "--threads", "2", "-o", "F.mtx"},
                                         "analytic visible pairs", std::chrono::milliseconds(0)),
                      "analytic visible pairs");
}

TEST_CASE(
    "cli interrupt: the late phases of a 10^5-patch Monte-Carlo solve stop within a second of "
    "SIGTERM" *
    doctest::test_suite("slow")) {
    // city-60 (104,761 patches), mc-hemisphere rows into sparse storage in 13 blocks: the rows
    // take seconds, then each block's threshold into CSR and the diagnosis tenths of a second
    // each, so the signal goes as the phase begins.
    for (const std::string phase : {"threshold", "diagnose"}) {
        CAPTURE(phase);
        TempDir work, capture;
        check_prompt_stop(interrupt_in_phase(work, capture,
                                             {"solve", "city-60", "--method", "mc-hemisphere",
                                              "--samples", "100", "--threads", "2", "-o", "B.csv"},
                                             phase, std::chrono::milliseconds(0)),
                          phase);
    }
}
