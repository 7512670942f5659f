#include "formfactor/matrix/aggregate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "formfactor/core/cancel.h"
#include "formfactor/core/error.h"
#include "formfactor/core/phase.h"

namespace formfactor {

PatchGroups surface_groups(const Scene& scene) {
    PatchGroups g;
    const std::size_t ns = scene.surfaces.size();
    std::vector<int> group_of_surface(ns, -1);
    for (std::size_t s = 0; s < ns; ++s) {
        const Surface& x = scene.surfaces[s];
        if (x.obstruction || x.combine >= 0) continue;
        group_of_surface[s] = static_cast<int>(g.names.size());
        g.names.push_back(x.name);
        g.surfaces.push_back({static_cast<int>(s)});
    }
    for (std::size_t s = 0; s < ns; ++s) {
        const Surface& x = scene.surfaces[s];
        if (x.obstruction || x.combine < 0) continue;
        // Follow the chain to a surface that is not combined itself.
        int t = x.combine;
        for (std::size_t hops = 0; t >= 0 && hops <= ns; ++hops) {
            if (static_cast<std::size_t>(t) >= ns)
                throw GeometryError("surface '" + x.name + "' is combined with surface " +
                                    std::to_string(t + 1) + ", which does not exist");
            if (scene.surfaces[static_cast<std::size_t>(t)].combine < 0) break;
            t = scene.surfaces[static_cast<std::size_t>(t)].combine;
        }
        const int grp = t >= 0 ? group_of_surface[static_cast<std::size_t>(t)] : -1;
        if (grp < 0)
            throw GeometryError("surface '" + x.name +
                                "' is combined with an obstruction-only surface or a cycle");
        group_of_surface[s] = grp;
        g.surfaces[static_cast<std::size_t>(grp)].push_back(static_cast<int>(s));
    }
    g.group_of_patch.reserve(scene.patches.size());
    for (std::size_t p = 0; p < scene.patches.size(); ++p) {
        const int s = scene.patches[p].surface;
        if (s < 0 || static_cast<std::size_t>(s) >= ns ||
            group_of_surface[static_cast<std::size_t>(s)] < 0)
            throw GeometryError("patch " + std::to_string(p) +
                                " belongs to no radiating surface (surface index " +
                                std::to_string(s) + ")");
        g.group_of_patch.push_back(group_of_surface[static_cast<std::size_t>(s)]);
    }
    return g;
}

bool is_identity(const PatchGroups& groups) {
    if (groups.group_of_patch.size() != groups.size()) return false;
    for (std::size_t i = 0; i < groups.group_of_patch.size(); ++i)
        if (groups.group_of_patch[i] != static_cast<int>(i)) return false;
    return true;
}

namespace {

// A_G of every group; throws GeometryError for a patch in no valid group or a group without a
// patch of positive area.
std::vector<double> group_areas(const std::vector<double>& areas, const PatchGroups& groups) {
    const std::size_t n = areas.size(), m = groups.size();
    std::vector<double> area(m, 0.0);
    std::vector<std::size_t> count(m, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const int g = groups.group_of_patch[i];
        if (g < 0 || static_cast<std::size_t>(g) >= m)
            throw GeometryError("aggregate: patch " + std::to_string(i) + " is in group " +
                                std::to_string(g) + " (there are " + std::to_string(m) + ")");
        area[static_cast<std::size_t>(g)] += areas[i];
        ++count[static_cast<std::size_t>(g)];
    }
    for (std::size_t g = 0; g < m; ++g)
        if (count[g] == 0 || !(area[g] > 0.0))
            throw GeometryError("aggregate: group '" + groups.names[g] +
                                "' has no patch of positive area");
    return area;
}

}  // namespace

FormFactors aggregate(const FormFactors& f, const PatchGroups& groups) {
    const std::size_t n = f.size();
    const std::size_t m = groups.size();
    if (groups.group_of_patch.size() != n || f.areas.size() != n ||
        static_cast<std::size_t>(f.F.cols()) != n)
        throw GeometryError("aggregate: " + std::to_string(n) + " patches in the matrix, " +
                            std::to_string(f.areas.size()) + " areas, " +
                            std::to_string(groups.group_of_patch.size()) + " in the grouping");
    const bool se = f.standard_error.has_value();
    if (se && (f.standard_error->rows() != f.F.rows() || f.standard_error->cols() != f.F.cols()))
        throw GeometryError("aggregate: the standard errors do not match the matrix");
    std::vector<double> area = group_areas(f.areas, groups);

    // Columns first (N × M), then rows weighted by area.
    DenseMatrix cols =
        DenseMatrix::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(m));
    DenseMatrix var;
    if (se) var = DenseMatrix::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(m));
    announce_phase("aggregate");
    // O(N²) on one thread: a signal must not wait for the end.
    const CancellationFlag& cancel = current_cancellation();
    for (std::size_t i = 0; i < n; ++i) {
        cancel.throw_if_requested();
        const auto ii = static_cast<Eigen::Index>(i);
        for (std::size_t j = 0; j < n; ++j) {
            const auto jj = static_cast<Eigen::Index>(j);
            const auto h = static_cast<Eigen::Index>(groups.group_of_patch[j]);
            cols(ii, h) += f.F(ii, jj);
            if (se) {
                const double s = (*f.standard_error)(ii, jj);
                var(ii, h) += s * s;
            }
        }
    }
    FormFactors out;
    out.F = DenseMatrix::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
    DenseMatrix outvar;
    if (se) outvar = DenseMatrix::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(m));
    for (std::size_t i = 0; i < n; ++i) {
        const auto ii = static_cast<Eigen::Index>(i);
        const auto g = static_cast<Eigen::Index>(groups.group_of_patch[i]);
        const double a = f.areas[i];
        out.F.row(g) += a * cols.row(ii);
        if (se) outvar.row(g) += (a * a) * var.row(ii);
    }
    for (std::size_t g = 0; g < m; ++g) {
        const auto gg = static_cast<Eigen::Index>(g);
        out.F.row(gg) /= area[g];
        if (se) outvar.row(gg) = outvar.row(gg).cwiseSqrt() / area[g];
    }
    if (se) out.standard_error = std::move(outvar);
    out.areas = std::move(area);
    return out;
}

SparseFormFactors aggregate(const SparseFormFactors& f, const PatchGroups& groups) {
    const std::size_t n = f.n, m = groups.size();
    if (groups.group_of_patch.size() != n || f.areas.size() != n)
        throw GeometryError("aggregate: " + std::to_string(n) + " patches in the matrix, " +
                            std::to_string(f.areas.size()) + " areas, " +
                            std::to_string(groups.group_of_patch.size()) + " in the grouping");
    f.check();
    SparseFormFactors out;
    out.n = m;
    out.areas = group_areas(f.areas, groups);
    out.threshold = f.threshold;
    const bool se = f.standard_error.has_value();
    // The patches of each group, in patch order.
    std::vector<std::vector<std::size_t>> members(m);
    for (std::size_t i = 0; i < n; ++i)
        members[static_cast<std::size_t>(groups.group_of_patch[i])].push_back(i);
    // Row G: Σ_{i∈G} A_i F_ij into the column of j's group, over the stored entries only.
    std::vector<double> acc(m, 0.0), var(se ? m : 0, 0.0);
    std::vector<char> seen(m, 0);
    std::vector<std::int32_t> touched;
    out.indptr.assign(m + 1, 0);
    out.computed_row_sums.assign(m, 0.0);
    out.dropped.assign(m, 0.0);
    std::vector<double> errors;
    announce_phase("aggregate");
    const CancellationFlag& cancel = current_cancellation();
    for (std::size_t g = 0; g < m; ++g) {
        touched.clear();
        for (const std::size_t i : members[g]) {
            cancel.throw_if_requested();
            const double a = f.areas[i];
            out.computed_row_sums[g] += a * f.computed_row_sums[i];
            out.dropped[g] += a * f.dropped[i];
            for (auto e = f.indptr[i]; e < f.indptr[i + 1]; ++e) {
                const auto k = static_cast<std::size_t>(e);
                const auto h = static_cast<std::size_t>(
                    groups.group_of_patch[static_cast<std::size_t>(f.indices[k])]);
                if (!seen[h]) {
                    seen[h] = 1;
                    touched.push_back(static_cast<std::int32_t>(h));
                }
                acc[h] += a * f.values[k];
                if (se) var[h] += a * a * (*f.standard_error)[k] * (*f.standard_error)[k];
            }
        }
        std::sort(touched.begin(), touched.end());
        for (const std::int32_t h : touched) {
            const auto hh = static_cast<std::size_t>(h);
            out.indices.push_back(h);
            out.values.push_back(acc[hh] / out.areas[g]);
            if (se) errors.push_back(std::sqrt(var[hh]) / out.areas[g]);
            acc[hh] = 0.0;
            if (se) var[hh] = 0.0;
            seen[hh] = 0;
        }
        out.indptr[g + 1] = static_cast<std::int64_t>(out.indices.size());
        out.computed_row_sums[g] /= out.areas[g];
        out.dropped[g] /= out.areas[g];
    }
    if (se) out.standard_error = std::move(errors);
    return out;
}

FormFactors aggregate_per_surface(const Scene& scene, const FormFactors& f) {
    return aggregate(f, surface_groups(scene));
}

}  // namespace formfactor
