// Interrupts: SIGINT or SIGTERM during a long computation stops it promptly and leaves neither an
// output file nor a temporary file behind; the CLI says so in one line and dies of the signal.

#include <doctest/doctest.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
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

// Runs `formfactor args...` in `work` (stdout and stderr captured in `capture`), sends `sig`
// after `delay`, and waits for it to end.
Interrupted interrupt(const TempDir& work, const TempDir& capture,
                      const std::vector<std::string>& args, int sig,
                      std::chrono::milliseconds delay) {
    const std::string out = capture.file("stdout.txt"), err = capture.file("stderr.txt");
    std::vector<std::string> argv_s = {FF_CLI_PATH};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
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
        ::execv(argv[0], argv.data());
        ::_exit(127);
    }
    std::this_thread::sleep_for(delay);
    Interrupted r;
    int status = 0;
    // The process must still be computing when the signal comes, else the test proves nothing.
    REQUIRE(::waitpid(pid, &status, WNOHANG) == 0);
    const auto sent = std::chrono::steady_clock::now();
    REQUIRE(::kill(pid, sig) == 0);
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    r.seconds_after =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
    r.status = status;
    r.err = read_text(err);
    for (const auto& entry : std::filesystem::directory_iterator(work.path()))
        r.left.push_back(entry.path().filename().string());
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
