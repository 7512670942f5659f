// Which rank keeps which rows of F (compute_distributed_rows(), distribute_rows()): the moves
// of kept blocks that even out a product's work over the ranks, the blocks on the wire, and
// distribute_rows()'s scatter of a whole F from rank 0.

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <map>
#include <new>
#include <optional>

#include "mpi_internal.h"

namespace formfactor::distributed {

namespace {

void put_kept_block(WireWriter& w, const KeptBlock& b, std::size_t n) {
    w.put(b.rows);
    if (kept_rows().sparse) {
        w.put_vector(b.indptr);
        w.put_vector(b.indices);
        w.put_vector(b.values);
    } else {
        w.put_array(b.row(b.rows.begin, n), b.rows.size() * n);
    }
}

KeptBlock get_kept_block(WireReader& r, std::size_t n) {
    const auto rows = r.get<RowRange>();
    if (!kept_rows().sparse) {
        const char* data = nullptr;
        if (r.get_array<double>(&data) != rows.size() * n)
            throw Error("distributed: a block of the wrong size");
        // Copied into place at the alignment the rows have in the whole matrix.
        std::vector<double> values(rows.size() * n);
        if (!values.empty()) std::memcpy(values.data(), data, values.size() * sizeof(double));
        return keep_dense(rows, values.data(), n);
    }
    KeptBlock b;
    b.rows = rows;
    b.indptr = r.get_vector<std::int64_t>();
    b.indices = r.get_vector<std::int32_t>();
    b.values = r.get_vector<double>();
    return b;
}

}  // namespace

// Every rank's part of the moves: sends the blocks it gives (non-blocking), receives the ones
// it gets, in the order of the moves (MPI keeps the order of one sender's messages). Returns
// the failure of this rank, or empty.
std::string make_moves(const std::vector<Move>& moves) {
    KeptRows& kept = kept_rows();
    std::string failure;
    auto fail = [&](std::string what) {
        if (failure.empty()) failure = std::move(what);
    };
    // Every move is a message, even when this rank cannot send its block (an empty one then):
    // its receiver must not wait for a block that will not come.
    std::vector<std::vector<char>> sent;
    std::vector<MPI_Request> requests;
    sent.reserve(moves.size());
    requests.reserve(moves.size());
    for (const Move& m : moves) {
        if (m.from != g_rank) continue;
        sent.emplace_back();
        try {
            const auto it =
                std::find_if(kept.blocks.begin(), kept.blocks.end(),
                             [&](const KeptBlock& b) { return b.rows.begin == m.rows.begin; });
            if (it == kept.blocks.end())
                throw Error(fmt::format("distributed: the block of rows {}..{} to move is not here",
                                        m.rows.begin, m.rows.end));
            WireWriter w;
            put_kept_block(w, *it, kept.n);
            sent.back() = std::move(w.bytes());
            kept.blocks.erase(it);
        } catch (const std::bad_alloc&) {
            sent.back().clear();
            fail(kOutOfMemory);
        } catch (const std::exception& e) {
            sent.back().clear();
            fail(e.what());
        }
        requests.emplace_back();
        MPI_Isend(sent.back().data(), message_size(sent.back()), MPI_BYTE, m.to, kTagMove, g_comm,
                  &requests.back());
    }
    // Every block this rank gets is received, after a failure too (so that no sender waits).
    for (const Move& m : moves) {
        if (m.to != g_rank) continue;
        try {
            const std::vector<char> bytes = receive_bytes(wait_for(m.from, kTagMove, nullptr));
            if (bytes.empty())
                throw Error(
                    fmt::format("distributed: rank {} could not send the block of rows "
                                "{}..{}",
                                m.from, m.rows.begin, m.rows.end));
            if (!failure.empty()) continue;
            WireReader r(bytes.data(), bytes.size());
            kept.blocks.push_back(get_kept_block(r, kept.n));
        } catch (const std::bad_alloc&) {
            fail(kOutOfMemory);
        } catch (const std::exception& e) {
            fail(e.what());
        }
    }
    for (MPI_Request& q : requests)
        complete(q, std::chrono::microseconds(20), std::chrono::microseconds(1000));
    std::sort(kept.blocks.begin(), kept.blocks.end(),
              [](const KeptBlock& a, const KeptBlock& b) { return a.rows.begin < b.rows.begin; });
    return failure;
}

std::vector<char> moves_bytes(const std::vector<Move>& moves) {
    WireWriter w;
    w.put_vector(moves);
    return std::move(w.bytes());
}

// After the moves every rank says whether its own went well (a gather to rank 0; a failed
// rank sends its message first).
std::vector<std::int32_t> gather_move_status(const std::string& failure) {
    if (!failure.empty() && g_rank != 0) {
        WireWriter w;
        w.put(Status::failed);
        w.put_string(failure);
        send_bytes(w.bytes(), 0, kTagResult);
    }
    std::int32_t mine = failure.empty() ? 0 : 1;
    std::vector<std::int32_t> all(static_cast<std::size_t>(g_rank == 0 ? g_size : 0));
    MPI_Gather(&mine, 1, MPI_INT32_T, all.data(), 1, MPI_INT32_T, 0, g_comm);
    return all;
}

void work_on_moves(const std::vector<char>& bytes) {
    std::string failure;
    std::vector<Move> moves;
    try {
        WireReader r(bytes.data(), bytes.size());
        moves = r.get_vector<Move>();
    } catch (const std::exception& e) {
        failure = e.what();
    }
    if (failure.empty()) failure = make_moves(moves);
    gather_move_status(failure);
}

// Rank 0, after the ranks gathered their status (gather_move_status()): the first failure, its
// own or a rank's, thrown as that rank's.
void throw_move_failures(const std::string& failure, const std::vector<std::int32_t>& status) {
    if (!failure.empty()) throw Error(failure);
    for (int r = 1; r < g_size; ++r)
        if (status[static_cast<std::size_t>(r)] != 0) {
            const std::vector<char> bytes = receive_bytes(wait_for(r, kTagResult, nullptr));
            WireReader reader(bytes.data(), bytes.size());
            reader.get<Status>();
            throw Error(fmt::format("rank {}: {}", r, reader.get_string()));
        }
}

namespace {

// The header of distribute_rows()'s blocks: which rows, whose, and the id they are kept under.
std::vector<char> scatter_bytes(std::uint64_t id, bool sparse, std::size_t n,
                                const Owners& owners) {
    WireWriter w;
    w.put(id);
    w.put<std::uint8_t>(sparse);
    w.put<std::uint64_t>(n);
    w.put<std::uint64_t>(owners.size());
    for (const auto& blocks : owners) w.put_vector(blocks);
    return std::move(w.bytes());
}

}  // namespace

// A worker's part of distribute_rows(): its block from rank 0 (a flag first: rank 0 that failed
// on the way sends no block), then its status.
void work_on_scatter(const std::vector<char>& bytes) {
    WireReader r(bytes.data(), bytes.size());
    const auto id = r.get<std::uint64_t>();
    const bool sparse = r.get<std::uint8_t>() != 0;
    const auto n = r.get<std::uint64_t>();
    Owners owners(r.get<std::uint64_t>());
    for (auto& blocks : owners) blocks = r.get_vector<RowRange>();
    KeptRows& kept = kept_rows();
    kept = KeptRows{};
    kept.sparse = sparse;
    kept.n = n;
    kept_id() = id;
    std::string failure;
    if (!owners.at(static_cast<std::size_t>(g_rank)).empty()) {
        try {
            const std::vector<char> got = receive_bytes(wait_for(0, kTagMove, nullptr));
            WireReader block(got.data(), got.size());
            if (block.get<std::uint8_t>() != 0) kept.blocks.push_back(get_kept_block(block, n));
        } catch (const std::bad_alloc&) {
            failure = kOutOfMemory;
        } catch (const std::exception& e) {
            failure = e.what();
        }
    }
    gather_move_status(failure);
}

namespace {

// Rank 0: distribute_rows() over the ranks. The blocks go one at a time, so that rank 0 holds
// at most its own block and one other besides F.
DistributedRows scatter_rows(const WholeRows& whole) {
    if (g_size <= 1 || g_rank != 0) return distribute_rows_here(whole);
    DistributedRows out = whole.head;
    const std::size_t n = out.n;
    KeptRows& kept = kept_rows();
    kept = KeptRows{};
    kept.sparse = out.sparse;
    kept.n = n;
    const std::uint64_t id = ++kept_id();
    Owners owners(static_cast<std::size_t>(g_size));
    out.rows_per_rank.assign(owners.size(), 0.0);
    for (std::size_t r = 0; r < whole.blocks.size() && r < owners.size(); ++r)
        if (whole.blocks[r].size() > 0) {
            owners[r].push_back(whole.blocks[r]);
            out.rows_per_rank[r] = double(whole.blocks[r].size());
        }
    broadcast_command(kCommandScatter, scatter_bytes(id, out.sparse, n, owners));
    out.row_sums.assign(n, 0.0);
    std::string failure;
    for (std::size_t r = 0; r < owners.size(); ++r) {
        if (owners[r].empty()) continue;
        WireWriter w;
        try {
            if (!failure.empty()) throw Error(failure);
            KeptBlock b = whole.block(owners[r].front());
            const std::vector<double> sums = kept_row_sums(b, n, out.sparse);
            std::copy(sums.begin(), sums.end(),
                      out.row_sums.begin() + std::ptrdiff_t(b.rows.begin));
            if (r == 0) {
                kept.blocks.push_back(std::move(b));
                continue;
            }
            w.put<std::uint8_t>(1);
            put_kept_block(w, b, n);
        } catch (const std::bad_alloc&) {
            if (failure.empty()) failure = kOutOfMemory;
        } catch (const std::exception& e) {
            if (failure.empty()) failure = e.what();
        }
        if (r == 0) continue;
        if (!failure.empty()) {
            w = WireWriter{};
            w.put<std::uint8_t>(0);
        }
        send_bytes(w.bytes(), int(r), kTagMove);
    }
    throw_move_failures(failure, gather_move_status(failure));
    g_owners = std::move(owners);
    out.id = id;
    return out;
}

}  // namespace

DistributedRows distribute_rows(const FormFactors& F) {
    return scatter_rows(whole_rows(F, g_rank == 0 ? g_size : 1));
}

DistributedRows distribute_rows(const SparseFormFactors& F) {
    return scatter_rows(whole_rows(F, g_rank == 0 ? g_size : 1));
}

}  // namespace formfactor::distributed
