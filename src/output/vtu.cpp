#include "formfactor/output/vtu.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <ostream>

#include "core/text_numbers.h"
#include "formfactor/core/atomic_file.h"
#include "formfactor/core/error.h"
#include "formfactor/geometry/polygon.h"

namespace formfactor {

namespace {

// VTK cell type numbers (vtkCellType.h).
constexpr int kVtkTriangle = 5;
constexpr int kVtkPolygon = 7;
constexpr int kVtkQuad = 9;

int cell_type(const Polygon& p) {
    if (p.size() == 3) return kVtkTriangle;
    if (p.size() == 4 && is_convex(p)) return kVtkQuad;
    return kVtkPolygon;
}

bool plain_name(const std::string& s) {
    if (s.empty()) return false;
    for (unsigned char c : s)
        if (!(std::isalnum(c) || c == '_' || c == '-' || c == '.')) return false;
    return true;
}

void flush_if_large(std::ostream& out, detail::TextBuffer& buf) {
    if (buf.size() >= (std::size_t(1) << 20)) {
        out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
        buf.clear();
    }
}

// Values separated by spaces, a line break every `per_line`.
template <class T, class Print>
void put_values(std::ostream& out, detail::TextBuffer& buf, const std::vector<T>& values,
                std::size_t per_line, Print print) {
    for (std::size_t k = 0; k < values.size(); ++k) {
        char* p = buf.room(detail::kMaxNumberChars + 2);
        p = print(p, values[k]);
        *p++ = (k + 1) % per_line == 0 || k + 1 == values.size() ? '\n' : ' ';
        buf.commit(p);
        flush_if_large(out, buf);
    }
}

void put_integers(std::ostream& out, detail::TextBuffer& buf, const std::vector<long long>& v,
                  std::size_t per_line) {
    put_values(out, buf, v, per_line,
               [](char* p, long long x) { return detail::print_integer(p, x); });
}

void put_doubles(std::ostream& out, detail::TextBuffer& buf, const std::vector<double>& v,
                 std::size_t per_line) {
    put_values(out, buf, v, per_line, [](char* p, double x) { return detail::print_g17(p, x); });
}

}  // namespace

std::vector<VtuField> row_sum_fields(const std::vector<double>& areas,
                                     const std::vector<double>& row_sums) {
    if (areas.size() != row_sums.size())
        throw Error(fmt::format("{} areas for {} row sums", areas.size(), row_sums.size()));
    VtuField sky{"sky_factor", 1, row_sums};
    for (double& s : sky.values) s = 1.0 - s;
    return {VtuField{"area", 1, areas}, VtuField{"row_sum", 1, row_sums}, std::move(sky)};
}

std::vector<VtuField> form_factor_fields(const FormFactors& ff, std::optional<std::size_t> row) {
    const std::size_t n = ff.size();
    if (row && *row >= n)
        throw OptionError("row", fmt::format("patch {} does not exist (the scene has {} patches, "
                                             "0 to {})",
                                             *row, n, n == 0 ? 0 : n - 1));
    std::vector<double> sums(n, 0.0);
    for (std::size_t i = 0; i < n; ++i) sums[i] = ff.F.row(static_cast<Eigen::Index>(i)).sum();
    std::vector<VtuField> fields = row_sum_fields(ff.areas, sums);
    if (ff.standard_error) {
        VtuField se{"row_sum_standard_error", 1, std::vector<double>(n, 0.0)};
        for (std::size_t i = 0; i < n; ++i)
            se.values[i] = ff.standard_error->row(static_cast<Eigen::Index>(i)).norm();
        fields.push_back(std::move(se));
    }
    if (row) {
        const auto r = static_cast<Eigen::Index>(*row);
        VtuField f{fmt::format("F_from_{}", *row), 1, std::vector<double>(n)};
        for (std::size_t j = 0; j < n; ++j) f.values[j] = ff.F(r, static_cast<Eigen::Index>(j));
        fields.push_back(std::move(f));
        if (ff.standard_error) {
            VtuField s{fmt::format("F_from_{}_standard_error", *row), 1, std::vector<double>(n)};
            for (std::size_t j = 0; j < n; ++j)
                s.values[j] = (*ff.standard_error)(r, static_cast<Eigen::Index>(j));
            fields.push_back(std::move(s));
        }
    }
    return fields;
}

void append_solution_fields(std::vector<VtuField>& fields, const RadiosityResult& result) {
    VtuField b{"radiosity", 3, {}};
    b.values.reserve(3 * result.radiosity.size());
    for (const Rgb& c : result.radiosity)
        for (int k = 0; k < 3; ++k) b.values.push_back(c[k]);
    fields.push_back(std::move(b));
}

void append_solution_fields(std::vector<VtuField>& fields, const ThermalResult& result) {
    fields.push_back({"emissivity", 1, result.emissivity});
    fields.push_back({"temperature", 1, result.temperature});
    fields.push_back({"radiosity", 1, result.radiosity});
    fields.push_back({"net_flux", 1, result.net_flux});
    fields.push_back({"net_power", 1, result.net_power});
}

void write_vtu(std::ostream& out, const Scene& scene, const std::vector<VtuField>& fields) {
    const std::size_t n = scene.patches.size();
    for (const VtuField& f : fields) {
        if (!plain_name(f.name))
            throw Error(
                fmt::format("VTU field name '{}' is not plain (letters, digits, _ - .)", f.name));
        if (f.components < 1 || f.values.size() != n * static_cast<std::size_t>(f.components))
            throw Error(fmt::format("VTU field '{}' has {} values for {} patches × {} components",
                                    f.name, f.values.size(), n, f.components));
    }
    std::vector<double> points;
    std::vector<long long> connectivity, offsets, types, patch_index, surface_index;
    for (std::size_t i = 0; i < n; ++i) {
        const Patch& p = scene.patches[i];
        for (const Vec3& v : p.polygon.vertices) {
            connectivity.push_back(static_cast<long long>(points.size() / 3));
            points.insert(points.end(), {v.x(), v.y(), v.z()});
        }
        offsets.push_back(static_cast<long long>(connectivity.size()));
        types.push_back(cell_type(p.polygon));
        patch_index.push_back(static_cast<long long>(i));
        surface_index.push_back(p.surface);
    }
    detail::TextBuffer buf;
    buf.append(fmt::format(
        "<?xml version=\"1.0\"?>\n"
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
        "header_type=\"UInt64\">\n"
        "  <UnstructuredGrid>\n"
        "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n"
        "      <Points>\n"
        "        <DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
        points.size() / 3, n));
    put_doubles(out, buf, points, 3);
    buf.append(
        "        </DataArray>\n"
        "      </Points>\n"
        "      <Cells>\n"
        "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    put_integers(out, buf, connectivity, 16);
    buf.append(
        "        </DataArray>\n"
        "        <DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    put_integers(out, buf, offsets, 16);
    buf.append(
        "        </DataArray>\n"
        "        <DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    put_integers(out, buf, types, 32);
    buf.append("        </DataArray>\n      </Cells>\n");
    const std::string scalars = fields.empty() ? std::string("patch") : fields.front().name;
    buf.append(fmt::format("      <CellData Scalars=\"{}\">\n", scalars));
    buf.append("        <DataArray type=\"Int64\" Name=\"patch\" format=\"ascii\">\n");
    put_integers(out, buf, patch_index, 16);
    buf.append("        </DataArray>\n");
    buf.append("        <DataArray type=\"Int64\" Name=\"surface\" format=\"ascii\">\n");
    put_integers(out, buf, surface_index, 16);
    buf.append("        </DataArray>\n");
    for (const VtuField& f : fields) {
        buf.append(
            fmt::format("        <DataArray type=\"Float64\" Name=\"{}\" "
                        "NumberOfComponents=\"{}\" format=\"ascii\">\n",
                        f.name, f.components));
        put_doubles(out, buf, f.values, static_cast<std::size_t>(f.components));
        buf.append("        </DataArray>\n");
    }
    buf.append(
        "      </CellData>\n"
        "    </Piece>\n"
        "  </UnstructuredGrid>\n"
        "</VTKFile>\n");
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

void write_vtu(const std::string& path, const Scene& scene, const std::vector<VtuField>& fields) {
    write_file_atomically(path, [&](std::ostream& out) { write_vtu(out, scene, fields); });
}

}  // namespace formfactor
