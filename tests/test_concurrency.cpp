// Thread safety: computations started at the same time from several std::threads of one process
// (each with its own parallel loop inside) give bit for bit what they give one at a time. The
// cases carry the `threads` label; `make test-tsan` runs them under ThreadSanitizer.

#include <doctest/doctest.h>

#include <chrono>
#include <functional>
#include <latch>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "formfactor/core/cancel.h"
#include "formfactor/core/parallel.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/room.h"
#include "formfactor/scene/scene.h"
#include "support/method_runner.h"

using formfactor::testing::run_method;

using namespace formfactor;

namespace {

// Threads each computation uses inside (its parallel_for). Under ThreadSanitizer one: TBB comes
// uninstrumented from Debian, so the synchronisation inside its scheduler is invisible to TSan
// and every result a worker hands back would be reported as a race. The concurrency under test
// is that of the std::threads below, which TSan sees whole.
#if defined(__SANITIZE_THREAD__)
constexpr int kInnerThreads = 1;
#else
constexpr int kInnerThreads = 2;
#endif

Scene scene(const std::string& name, int n) {
    Scene s =
        name.rfind("room", 0) == 0 ? room_scene(n, RoomBox::kObstruction) : builtin_scene(name);
    if (name.rfind("room", 0) != 0) {
        SubdivisionOptions o;
        o.n = n;
        subdivide(s, o);
    }
    return s;
}

struct Job {
    std::string method;
    const Scene* scene;
    MethodOptions options;
};

Job job(const std::string& method, const Scene& s, std::uint64_t samples = 0) {
    Job j{method, &s, {}};
    j.options.threads = kInnerThreads;
    j.options.samples = samples;
    j.options.resolution = 64;
    j.options.seed = 7;
    return j;
}

FormFactors compute(const Job& j) {
    nlohmann::json details;
    return run_method(*make_method(j.method), *j.scene, j.options, details);
}

// Same bits: F, and the standard errors when the method gives them.
void require_identical(const FormFactors& a, const FormFactors& b, const std::string& what) {
    INFO(what);
    REQUIRE(a.F.rows() == b.F.rows());
    REQUIRE(a.F.cols() == b.F.cols());
    CHECK(a.F == b.F);
    CHECK(a.areas == b.areas);
    REQUIRE(a.standard_error.has_value() == b.standard_error.has_value());
    if (a.standard_error) CHECK(*a.standard_error == *b.standard_error);
}

// Runs the jobs one at a time, then all at once (one std::thread each, released together), and
// compares.
void check_concurrent(const std::vector<Job>& jobs) {
    std::vector<FormFactors> alone;
    for (const Job& j : jobs) alone.push_back(compute(j));

    std::vector<FormFactors> together(jobs.size());
    std::vector<std::string> errors(jobs.size());
    std::latch start(static_cast<std::ptrdiff_t>(jobs.size()));
    std::vector<std::thread> threads;
    for (std::size_t k = 0; k < jobs.size(); ++k) {
        threads.emplace_back([&, k] {
            start.arrive_and_wait();
            try {
                together[k] = compute(jobs[k]);
            } catch (const std::exception& e) {
                errors[k] = e.what();
            }
        });
    }
    for (std::thread& t : threads) t.join();
    for (std::size_t k = 0; k < jobs.size(); ++k) {
        INFO(jobs[k].method);
        REQUIRE(errors[k].empty());
        require_identical(alone[k], together[k], jobs[k].method + " on " + jobs[k].scene->name);
    }
}

}  // namespace

TEST_CASE("threads: two scenes computed at once equal one at a time" *
          doctest::test_suite("threads")) {
    const Scene cube = scene("cube", 3);
    const Scene cornell = scene("cornell", 2);
    check_concurrent({job("analytic", cube), job("mc-hemisphere", cornell, 2000)});
}

TEST_CASE("threads: the same scene computed twice at once" * doctest::test_suite("threads")) {
    const Scene cornell = scene("cornell", 2);
    check_concurrent({job("mc-hemisphere", cornell, 2000), job("mc-hemisphere", cornell, 2000)});
    const Scene room = scene("room", 2);
    check_concurrent({job("analytic", room), job("analytic", room)});
}

TEST_CASE("threads: every method at once and each on its own scene" *
          doctest::test_suite("threads")) {
    const Scene cube = scene("cube", 3);
    const Scene room = scene("room", 2);
    const Scene cornell = scene("cornell-empty", 2);
    const Scene plates = scene("plates", 3);
    const Scene perpendicular = scene("perpendicular", 3);
    check_concurrent({job("analytic", cube), job("analytic", room),
                      job("mc-hemisphere", cornell, 1000), job("mc-area", cornell, 64),
                      job("mc-target", room, 64), job("hemicube", plates),
                      job("hemiplane", perpendicular)});
}

TEST_CASE("threads: a cancellation request stops parallel_for with Cancelled" *
          doctest::test_suite("threads")) {
    CancellationFlag flag;
    std::atomic<std::size_t> ran{0};
    // The body requests cancellation at its 10th row: no row starts after the request is seen.
    CHECK_THROWS_AS(parallel_for(
                        100000, 2,
                        [&](std::size_t) {
                            if (ran.fetch_add(1) == 9) flag.request();
                        },
                        flag),
                    Cancelled);
    CHECK(ran.load() < 1000);
    flag.reset();
    ran = 0;
    parallel_for(
        100, 2, [&](std::size_t) { ++ran; }, flag);
    CHECK(ran.load() == 100);
    // A flag requested before the loop: nothing runs.
    flag.request();
    ran = 0;
    CHECK_THROWS_AS(parallel_for(
                        100, 1, [&](std::size_t) { ++ran; }, flag),
                    Cancelled);
    CHECK(ran.load() == 0);
}

TEST_CASE(
    "threads: parallel_for_each runs every iteration once and spreads costly ones that come "
    "together over both threads" *
    doctest::test_suite("threads")) {
    // Eight slow iterations first, then many quick ones: in chunks, the slow ones would all
    // run on the thread that took the first chunk.
    constexpr std::size_t n = 4000, slow = 8;
    std::vector<std::atomic<int>> ran(n);
    std::mutex m;
    std::set<std::thread::id> slow_threads;
    parallel_for_each(n, 2, [&](std::size_t i) {
        ++ran[i];
        if (i < slow) {
            std::this_thread::sleep_for(std::chrono::milliseconds(40));
            std::lock_guard<std::mutex> lock(m);
            slow_threads.insert(std::this_thread::get_id());
        }
    });
    for (std::size_t i = 0; i < n; ++i) REQUIRE(ran[i].load() == 1);
    CHECK(slow_threads.size() == 2);
}
