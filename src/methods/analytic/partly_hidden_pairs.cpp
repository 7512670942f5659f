// The `analytic` method's partly hidden pairs apart from its rows (formfactor/methods/
// partly_hidden.h): the classification of a scene that may obstruct, in parts and as bytes for
// other processes (an MPI run shares it out over the ranks), and the integration of any part of
// the list of partly hidden pairs, each settled as the rows settle it (partial_pair.h: its
// bracket, the umbrae of its occluders, or Walton's adaptive integration, NISTIR 6925), bit for
// bit. See docs/analytic.md, "Obstructed scenes".

#include "methods/analytic/partly_hidden_pairs.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "formfactor/core/error.h"
#include "formfactor/core/parallel.h"
#include "formfactor/methods/partly_hidden.h"
#include "kernels/unobstructed.h"
#include "methods/analytic/analytic_method.h"
#include "methods/analytic/classification.h"
#include "methods/analytic/partial_pair.h"

namespace formfactor {

namespace {

using detail::add_pair;
using detail::checked_tolerance;
using detail::combined;
using detail::integrate_partial;
using detail::PairOutput;
using detail::PartialPair;
using detail::PartialValue;
using detail::prepare_obstructions;
using detail::sample_stride;
using detail::ThreadStats;

}  // namespace

PartlyHiddenPairs::PartlyHiddenPairs(const Scene& scene, const MethodOptions& options, bool sparse,
                                     bool classify)
    : impl_(std::make_unique<Impl>(scene, options)) {
    Impl& m = *impl_;
    m.visible_tol = AnalyticMethod::visible_tolerance(options, true);
    m.sparse = sparse;
    m.tol = checked_tolerance(options);
    const MethodContext ctx{scene, options, nullptr, nullptr, RowRange{}, nullptr, nullptr};
    if (classify) {
        prepare_obstructions(ctx, sparse, m.S);
    } else {
        prepare_blockers(ctx, m.S);
        m.task_order = detail::classification_order(m.S);
    }
    {
        std::vector<const Polygon*> polys(scene.patches.size());
        for (std::size_t p = 0; p < polys.size(); ++p) polys[p] = &scene.patches[p].polygon;
        m.table = detail::make_patch_table(polys, options.threads);
    }
    if (classify) m.list_pairs();
}

// The bytes of classify(): per task, seven counts (hidden, visible, partial and candidate
// entries, node pairs, visible and hidden patch pairs), then the four arrays as they are in
// memory.
namespace {

template <class T>
void put_array(std::vector<char>& out, const std::vector<T>& v) {
    const char* p = reinterpret_cast<const char*>(v.data());
    out.insert(out.end(), p, p + v.size() * sizeof(T));
}

class ByteReader {
  public:
    ByteReader(const char* data, std::size_t size) : data_(data), size_(size) {}
    bool done() const { return at_ == size_; }
    void read(void* dst, std::size_t bytes) {
        if (bytes > size_ - at_) throw Error("analytic: a classification cut short");
        if (bytes == 0) return;  // dst may be an empty vector's null data()
        std::memcpy(dst, data_ + at_, bytes);
        at_ += bytes;
    }
    template <class T>
    void array(std::vector<T>& v, std::uint64_t count) {
        if (count > (size_ - at_) / sizeof(T)) throw Error("analytic: a classification cut short");
        v.resize(static_cast<std::size_t>(count));
        read(v.data(), v.size() * sizeof(T));
    }

  private:
    const char* data_;
    std::size_t size_;
    std::size_t at_ = 0;
};

}  // namespace

std::size_t PartlyHiddenPairs::classification_tasks() const {
    return detail::classification_tasks(impl_->S);
}

std::vector<char> PartlyHiddenPairs::classify(RowRange tasks) const {
    const Impl& m = *impl_;
    tasks = tasks.clamped(detail::classification_tasks(m.S));
    if (m.task_order.size() != detail::classification_tasks(m.S))
        throw Error("analytic: classify() on pairs classified whole");
    std::vector<PairOutput> outputs(tasks.size());
    detail::classify_task_list(m.S, m.task_order.data() + tasks.begin, tasks.size(), m.sparse,
                               m.options.threads, outputs.data());
    std::vector<char> out;
    for (const PairOutput& o : outputs) {
        const std::uint64_t counts[7] = {
            o.hidden.size(), o.visible.size(),      o.partial.size(),    o.cand.bytes.size(),
            o.node_pairs,    o.visible_patch_pairs, o.hidden_patch_pairs};
        const char* c = reinterpret_cast<const char*>(counts);
        out.insert(out.end(), c, c + sizeof(counts));
        put_array(out, o.hidden);
        put_array(out, o.visible);
        put_array(out, o.partial);
        put_array(out, o.cand.bytes);
    }
    return out;
}

void PartlyHiddenPairs::set_classification(const char* bytes, std::size_t size) {
    Impl& m = *impl_;
    if (!m.S.outputs.empty()) throw Error("analytic: the pairs are classified already");
    const std::size_t tasks = detail::classification_tasks(m.S);
    if (m.task_order.size() != tasks) throw Error("analytic: the pairs are classified already");
    std::vector<PairOutput> outputs(tasks);
    ByteReader r(bytes, size);
    for (std::size_t position = 0; position < tasks; ++position) {
        PairOutput& o = outputs[m.task_order[position]];
        std::uint64_t counts[7];
        r.read(counts, sizeof(counts));
        r.array(o.hidden, counts[0]);
        r.array(o.visible, counts[1]);
        r.array(o.partial, counts[2]);
        r.array(o.cand.bytes, counts[3]);
        o.node_pairs = static_cast<std::size_t>(counts[4]);
        o.visible_patch_pairs = static_cast<std::size_t>(counts[5]);
        o.hidden_patch_pairs = static_cast<std::size_t>(counts[6]);
        std::vector<int> ids;
        for (const PartialPair& p : o.partial) {
            bool ok = o.cand.decode(p.cand_first, ids);
            for (std::size_t k = 0; k < ids.size() && ok; ++k)
                ok = static_cast<std::size_t>(ids[k]) < m.S.blockers.size();
            if (!ok) throw Error("analytic: a classification with candidates out of range");
        }
    }
    if (!r.done()) throw Error("analytic: a classification of more tasks than the scene has");
    m.S.outputs = std::move(outputs);
    m.list_pairs();
}

void PartlyHiddenPairs::Impl::list_pairs() {
    Impl& m = *this;
    for (std::size_t k = 0; k < m.S.outputs.size(); ++k)
        for (const PartialPair& p : m.S.outputs[k].partial) {
            m.partial.push_back(p);
            m.cand_task.push_back(k);
        }
    // Neighbouring pairs in the list often share their blockers and cost alike (the pairs of
    // two surfaces); a part of every stride-th pair is a sample of the whole list.
    const std::size_t count = m.partial.size();
    const std::size_t stride = sample_stride(count);
    m.order.resize(count);
    for (std::size_t j = 0; j < count; ++j) m.order[j] = detail::strided_pair(j, count, stride);
}

PartlyHiddenPairs::~PartlyHiddenPairs() = default;

std::size_t PartlyHiddenPairs::count() const { return impl_->partial.size(); }

bool PartlyHiddenPairs::has_values() const { return impl_->has_values; }

PartlyHiddenValues PartlyHiddenPairs::integrate(RowRange part) const {
    const Impl& m = *impl_;
    const Scene& scene = m.scene;
    const std::size_t n = scene.patches.size();
    part = part.clamped(m.partial.size());
    // The part's unobstructed values, bit for bit the ones of the rows (kernels/unobstructed.h).
    std::vector<std::vector<std::int32_t>> cols(n);
    for (std::size_t q = part.begin; q < part.end; ++q) {
        const PartialPair& p = m.partial[m.order[q]];
        cols[static_cast<std::size_t>(std::min(p.i, p.j))].push_back(std::max(p.i, p.j));
    }
    parallel_for(n, m.options.threads, [&](std::size_t a) {
        std::sort(cols[a].begin(), cols[a].end());
        cols[a].erase(std::unique(cols[a].begin(), cols[a].end()), cols[a].end());
    });
    std::vector<const Polygon*> polys(n);
    for (std::size_t p = 0; p < n; ++p) polys[p] = &scene.patches[p].polygon;
    std::vector<std::vector<double>> upper;
    std::vector<double> areas;
    detail::unobstructed_pairs(polys, m.visible_tol, m.options.threads, nullptr, cols, upper, areas,
                               m.table.get());
    auto at = [&](std::size_t a, std::size_t c) {
        const auto it =
            std::lower_bound(cols[a].begin(), cols[a].end(), static_cast<std::int32_t>(c));
        FF_ASSERT(it != cols[a].end() && *it == static_cast<std::int32_t>(c));
        return upper[a][static_cast<std::size_t>(it - cols[a].begin())];
    };
    PartlyHiddenValues out;
    out.f.assign(part.size(), 0.0);
    out.back.assign(part.size(), 0.0);
    out.integrated.assign(part.size(), 0);
    ThreadStats stats;
    parallel_for(part.size(), m.options.threads, [&](std::size_t q) {
        const std::size_t k = m.order[part.begin + q];
        const PartialValue v = integrate_partial(
            scene, m.S, m.partial[k], m.S.outputs[m.cand_task[k]].cand, m.tol,
            [&](std::size_t s, std::size_t r) {
                return s < r ? at(s, r) : detail::reciprocal_entry(at(r, s), areas[r], areas[s]);
            });
        out.f[q] = v.f;
        out.back[q] = v.back;
        out.integrated[q] = v.integrated ? 1 : 0;
        add_pair(stats.local(), v.stats);
    });
    out.stats = combined(stats);
    return out;
}

void PartlyHiddenPairs::write_lower_values(DenseMatrix& F) const {
    const Impl& m = *impl_;
    const auto n = static_cast<std::size_t>(m.scene.patches.size());
    if (!m.has_values || m.sparse)
        throw Error("analytic: no dense values of the partly hidden pairs");
    if (static_cast<std::size_t>(F.rows()) != n || static_cast<std::size_t>(F.cols()) != n)
        throw Error("analytic: the lower values of the partly hidden pairs need the whole F");
    double* out = F.data();
    for (std::size_t k = 0; k < m.partial.size(); ++k) {
        const PartialValue v = m.value(k);
        if (!v.integrated) continue;
        if (v.s > v.r)
            out[v.s * n + v.r] = v.f;
        else
            out[v.r * n + v.s] = v.back;
    }
}

void PartlyHiddenPairs::set_values(PartlyHiddenValues all) {
    Impl& m = *impl_;
    const std::size_t count = m.partial.size();
    if (all.f.size() != count || all.back.size() != count || all.integrated.size() != count)
        throw Error("analytic: the values of the wrong number of partly hidden pairs");
    PartlyHiddenValues& v = m.values;
    v.f.resize(count);
    v.back.resize(count);
    v.integrated.resize(count);
    for (std::size_t q = 0; q < count; ++q) {
        v.f[m.order[q]] = all.f[q];
        v.back[m.order[q]] = all.back[q];
        v.integrated[m.order[q]] = all.integrated[q];
    }
    v.stats = all.stats;
    m.has_values = true;
}

}  // namespace formfactor
