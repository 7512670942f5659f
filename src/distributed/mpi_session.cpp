// The MPI session of a process (formfactor/distributed/distributed.h): MPI started by a Session
// or lent by a Communicator, this rank's state, the waits and message helpers every command
// uses, and serve(), a worker's loop over rank 0's commands until finish(). Waits poll with
// short sleeps: a blocking MPI receive spins a core that the computation needs.

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <limits>
#include <thread>

#include "mpi_internal.h"

namespace formfactor::distributed {

bool g_active = false;  // MPI was initialised by a Session, or a Communicator is in scope
bool g_finished = false;
int g_rank = 0, g_size = 1, g_thread_level = MPI_THREAD_SINGLE;
MPI_Comm g_comm = MPI_COMM_WORLD;
RankShares g_shares;
Owners g_owners;  // rank 0: who keeps which rows of the last compute_distributed_rows()

namespace {

// The environment of a process that an MPI launcher started: Open MPI's mpirun, PMIx (Open
// MPI under srun), PMI (MPICH's hydra, srun --mpi=pmi2).
bool launched_by_mpi() {
    for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(name)) return true;
    return false;
}

}  // namespace

// Waits for a message from `source` with `tag` without spinning: probe, then sleep from 20 µs
// up to 1 ms. Throws Cancelled when `cancel` is requested meanwhile.
MPI_Status wait_for(int source, int tag, const CancellationFlag* cancel) {
    auto pause = std::chrono::microseconds(20);
    for (;;) {
        int flag = 0;
        MPI_Status status;
        MPI_Iprobe(source, tag, g_comm, &flag, &status);
        if (flag) return status;
        if (cancel) cancel->throw_if_requested();
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, std::chrono::microseconds(1000));
    }
}

// Waits for a non-blocking operation without spinning: test, then sleep from `first` up to
// `most`.
void complete(MPI_Request& request, std::chrono::microseconds first,
              std::chrono::microseconds most) {
    auto pause = first;
    for (int done = 0;;) {
        MPI_Test(&request, &done, MPI_STATUS_IGNORE);
        if (done) return;
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, most);
    }
}

std::vector<char> receive_bytes(const MPI_Status& probed) {
    std::vector<char> bytes;
    receive_bytes(probed, bytes);
    return bytes;
}

void receive_bytes(const MPI_Status& probed, std::vector<char>& into) {
    int count = 0;
    MPI_Get_count(&probed, MPI_BYTE, &count);
    into.resize(static_cast<std::size_t>(count));
    MPI_Recv(into.data(), count, MPI_BYTE, probed.MPI_SOURCE, probed.MPI_TAG, g_comm,
             MPI_STATUS_IGNORE);
}

int message_size(const std::vector<char>& bytes) {
    if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        throw ResourceError("distributed: a message of " + format_bytes(double(bytes.size())) +
                            " is more than MPI's 2 GB (use smaller blocks)");
    return static_cast<int>(bytes.size());
}

void send_bytes(const std::vector<char>& bytes, int dest, int tag) {
    MPI_Send(bytes.data(), message_size(bytes), MPI_BYTE, dest, tag, g_comm);
}

// Rank 0: a solve (kCommandSolve) or the moves of kept rows (kCommandMove) to every other rank.
void broadcast_command(std::int64_t command, const std::vector<char>& bytes) {
    std::int64_t size = static_cast<std::int64_t>(message_size(bytes));
    for (int r = 1; r < g_size; ++r) MPI_Send(&command, 1, MPI_INT64_T, r, kTagCommand, g_comm);
    MPI_Bcast(&size, 1, MPI_INT64_T, 0, g_comm);
    MPI_Bcast(const_cast<char*>(bytes.data()), static_cast<int>(size), MPI_BYTE, 0, g_comm);
}

std::vector<char> receive_job() {
    std::int64_t size = 0;
    MPI_Bcast(&size, 1, MPI_INT64_T, 0, g_comm);
    std::vector<char> bytes(static_cast<std::size_t>(size));
    MPI_Bcast(bytes.data(), static_cast<int>(size), MPI_BYTE, 0, g_comm);
    return bytes;
}

bool built_with_mpi() { return true; }

Session::Session(int& argc, char**& argv) {
    if (g_active || !launched_by_mpi()) return;
    MPI_Init_thread(&argc, &argv, MPI_THREAD_SERIALIZED, &g_thread_level);
    g_comm = MPI_COMM_WORLD;
    MPI_Comm_rank(g_comm, &g_rank);
    MPI_Comm_size(g_comm, &g_size);
    g_active = true;
}

Session::~Session() {
    if (!g_active) return;
    finish();
    MPI_Finalize();
    g_active = false;
}

struct Communicator::Saved {
    bool active, finished;
    int rank, size, thread_level;
    MPI_Comm comm;
};

Communicator::Communicator(std::int64_t fortran_handle) {
    int initialised = 0, finalised = 0;
    MPI_Initialized(&initialised);
    MPI_Finalized(&finalised);
    if (!initialised || finalised)
        throw Error("comm: MPI is not initialised in this process (import mpi4py.MPI first)");
    const MPI_Comm comm = MPI_Comm_f2c(static_cast<MPI_Fint>(fortran_handle));
    if (comm == MPI_COMM_NULL) throw OptionError("comm", "is MPI.COMM_NULL");
    saved_ = std::make_unique<Saved>(
        Saved{g_active, g_finished, g_rank, g_size, g_thread_level, g_comm});
    g_comm = comm;
    MPI_Comm_rank(g_comm, &g_rank);
    MPI_Comm_size(g_comm, &g_size);
    MPI_Query_thread(&g_thread_level);
    g_active = true;
    g_finished = false;
}

Communicator::~Communicator() {
    finish();
    g_active = saved_->active;
    g_finished = saved_->finished;
    g_rank = saved_->rank;
    g_size = saved_->size;
    g_thread_level = saved_->thread_level;
    g_comm = saved_->comm;
}

int Session::rank() const { return g_rank; }
int Session::size() const { return g_size; }
int rank() { return g_rank; }
int size() { return g_size; }

int serve() {
    if (!g_active || g_rank == 0) return 0;
    for (;;) {
        wait_for(0, kTagCommand, &current_cancellation());
        std::int64_t command = 0;
        MPI_Recv(&command, 1, MPI_INT64_T, 0, kTagCommand, g_comm, MPI_STATUS_IGNORE);
        if (command == kCommandJob)
            work_on_job(receive_job());
        else if (command == kCommandSolve)
            work_on_solve(receive_job());
        else if (command == kCommandMove)
            work_on_moves(receive_job());
        else if (command == kCommandScatter)
            work_on_scatter(receive_job());
        else if (command == kCommandOperator)
            work_on_hierarchical(receive_job());
        else if (command == kCommandOperatorSolve)
            work_on_operator_solve(receive_job());
        else if (command == kCommandOperatorProduct)
            work_on_operator_product(receive_job());
        else
            return 0;
    }
}

void finish() {
    if (!g_active || g_rank != 0 || g_finished) return;
    g_finished = true;
    for (int r = 1; r < g_size; ++r)
        MPI_Send(&kCommandFinish, 1, MPI_INT64_T, r, kTagCommand, g_comm);
}

const RankShares& last_rank_shares() { return g_shares; }

}  // namespace formfactor::distributed
