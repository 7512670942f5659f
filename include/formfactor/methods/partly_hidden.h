#pragma once
/// The `analytic` method's partly hidden pairs apart from its rows: the classification of a
/// scene that may obstruct and the integration of any part of the list it makes. A block of rows
/// needs the values of every partly hidden pair with a patch in it, so blocks computed on their
/// own integrate the pairs between two blocks twice; an MPI run instead prepares this on every
/// rank, classifies in parts over the ranks (classify(), set_classification()), hands out
/// parts of the list, gives every rank all the values, and then computes the rows with them
/// (MethodContext::partly_hidden): each pair is classified and integrated once.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "formfactor/core/types.h"
#include "formfactor/methods/method.h"
#include "formfactor/scene/scene.h"

namespace formfactor {

/// What the integration of some partly hidden pairs did: sums, maxima and counts (the same
/// whatever the order the pairs were done in). The keys of details["obstructions"] of the
/// analytic method's report (docs/analytic.md).
struct PartlyHiddenStats {
    static constexpr int kLevels = 16;
    std::array<std::size_t, kLevels + 1> levels{};  ///< integrated pairs per refinement level
    double max_error = 0;
    std::size_t points = 0, cells = 0, closed_forms = 0, proven_hidden = 0, capped = 0, changed = 0,
                bracketed = 0, settled_by_umbrae = 0, cells_bracketed = 0,
                cut_budget_spent = 0,      ///< pairs whose event cut left lines uncut (its budget)
        occluded_candidates = 0,           ///< candidates a solid hides (unoccluded_candidates)
        integrated_over_seeing_parts = 0;  ///< pairs integrated where the sender sees r only
    void add(const PartlyHiddenStats& o);
};

/// The values of some partly hidden pairs (k-th of a part: f[k] = F_sr, back[k] = F_rs, s the
/// smaller patch of the pair; integrated[k] = 0 where the unobstructed value is 0 and nothing
/// changes), and what their integration did.
struct PartlyHiddenValues {
    std::vector<double> f, back;
    std::vector<std::uint8_t> integrated;
    PartlyHiddenStats stats;
};

/// The partly hidden pairs of a scene that may obstruct (formfactor::may_obstruct()), classified
/// as the analytic method does: every process that prepares it for the same scene and options
/// gets the same list in the same order. Holds pointers into `scene`, which must outlive it.
class PartlyHiddenPairs {
  public:
    /// Classifies the pairs of `scene` (options.threads threads). sparse: keep the visible
    /// pairs too, for rows emitted sparse (MethodContext::sparse_rows); the rows computed
    /// with it must then be sparse, and dense otherwise.
    /// classify = false: only the blockers; the classification then comes in parts from
    /// classify() (done anywhere) through set_classification() (an MPI run shares it out
    /// over the ranks), and nothing else may be called before.
    PartlyHiddenPairs(const Scene& scene, const MethodOptions& options, bool sparse,
                      bool classify = true);
    ~PartlyHiddenPairs();
    PartlyHiddenPairs(const PartlyHiddenPairs&) = delete;
    PartlyHiddenPairs& operator=(const PartlyHiddenPairs&) = delete;

    /// The classification's tasks (one per unordered pair of plane groups of patches).
    std::size_t classification_tasks() const;
    /// The classification of the tasks at positions [tasks.begin, tasks.end) of an order that
    /// starts with the costliest (by an estimate), as bytes for set_classification() (a
    /// process running the same binary on the same scene and options reads them): positions
    /// shared out in order then end with small tasks. In parallel (options.threads); polls
    /// current_cancellation(). Only on pairs made with classify = false.
    std::vector<char> classify(RowRange tasks) const;
    /// Every task's classification: the bytes of classify() for consecutive ranges that cover
    /// [0, classification_tasks()), concatenated in order. Then as if classified here (the
    /// same pairs in the same order); an Error if the bytes are not that.
    void set_classification(const char* bytes, std::size_t size);
    void set_classification(const std::vector<char>& bytes) {
        set_classification(bytes.data(), bytes.size());
    }

    /// The number of partly hidden pairs.
    std::size_t count() const;
    /// Integrates the pairs at positions [part.begin, part.end) of an order that spreads them
    /// over the list (every so many pairs), so that a part costs about its share of the whole;
    /// values bit for bit the ones a single run of the method computes. In parallel
    /// (options.threads); polls current_cancellation().
    PartlyHiddenValues integrate(RowRange part) const;
    /// Every pair's values: the parts of integrate() for [0, count()) in order, concatenated
    /// (their stats summed). The rows computed with this object then take them.
    void set_values(PartlyHiddenValues all);
    /// True once set_values() was called.
    bool has_values() const;
    /// Writes into the whole dense F (n × n, row-major) every integrated pair's entry below
    /// the diagonal, as the method's rows give it (F_sr or its reciprocal F_rs): for F whose
    /// lower triangle was filled by reciprocity from blocks of its upper triangle
    /// (MethodContext::upper_triangle_only). Needs the values.
    void write_lower_values(DenseMatrix& F) const;

    struct Impl;
    const Impl& impl() const { return *impl_; }

  private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace formfactor
