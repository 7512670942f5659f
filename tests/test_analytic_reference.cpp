// Reference values and geometry copied from the project's reference catalog (Howell's catalog
// cases B-3, B-4, C-11, C-14, C-41 and two closed enclosures); each value was checked there
// against two independent integrations to 1e-13.

#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "formfactor/kernels/analytic.h"

using namespace formfactor;

namespace {

struct PointCase {
    const char* name;
    Vec3 x, n;
    Polygon p;
    double exact;
};

struct PolygonCase {
    const char* name;
    Polygon a, b;
    double exact;
};

struct NgonCase {
    const char* name;
    double r1, r2, h;
    int sides;
    bool area_matched;
    double exact;
};

const std::vector<PointCase> kPointCases = {
    {"B3_dA_parallel_rect_corner_a1_b1_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 1.0, 1.0), Vec3(1.0, 1.0, 1.0), Vec3(1.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.13853160599489298},
    {"B3_dA_parallel_rect_corner_a2_b1_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 1.0, 1.0), Vec3(2.0, 1.0, 1.0), Vec3(2.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.16737500991438375},
    {"B3_dA_parallel_rect_corner_a1_b3_c0.5", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 3.0, 0.5), Vec3(1.0, 3.0, 0.5), Vec3(1.0, 0.0, 0.5), Vec3(0.0, 0.0, 0.5)}},
     0.22269468089180283},
    {"B3_dA_parallel_rect_corner_a0.2_b5_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 5.0, 1.0), Vec3(0.2, 5.0, 1.0), Vec3(0.2, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.048867181718244536},
    {"B3_dA_parallel_rect_corner_a10_b10_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{
         {Vec3(0.0, 10.0, 1.0), Vec3(10.0, 10.0, 1.0), Vec3(10.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.24797140829531017},
    {"B3_dA_parallel_rect_corner_a0.05_b0.05_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{
         {Vec3(0.0, 0.05, 1.0), Vec3(0.05, 0.05, 1.0), Vec3(0.05, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.0007931313831388566},
    {"B4_dA_perpendicular_rect_a1_b1_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 1.0, 0.0), Vec3(1.0, 1.0, 0.0), Vec3(1.0, 1.0, 1.0), Vec3(0.0, 1.0, 1.0)}},
     0.05573419700255351},
    {"B4_dA_perpendicular_rect_a2_b1_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 1.0, 0.0), Vec3(2.0, 1.0, 0.0), Vec3(2.0, 1.0, 1.0), Vec3(0.0, 1.0, 1.0)}},
     0.06869729887559299},
    {"B4_dA_perpendicular_rect_a1_b2_c0.5", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 0.5, 0.0), Vec3(1.0, 0.5, 0.0), Vec3(1.0, 0.5, 2.0), Vec3(0.0, 0.5, 2.0)}},
     0.1587748045142993},
    {"B4_dA_perpendicular_rect_a0.5_b3_c2", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{{Vec3(0.0, 2.0, 0.0), Vec3(0.5, 2.0, 0.0), Vec3(0.5, 2.0, 3.0), Vec3(0.0, 2.0, 3.0)}},
     0.026824462758420865},
    {"B4_dA_perpendicular_rect_a4_b0.25_c1", Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0),
     Polygon{
         {Vec3(0.0, 1.0, 0.0), Vec3(4.0, 1.0, 0.0), Vec3(4.0, 1.0, 0.25), Vec3(0.0, 1.0, 0.25)}},
     0.007416314325767564},
};

const std::vector<PolygonCase> kPolygonCases = {
    {"C11_parallel_opposed_rect_a1_b1_c1",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 1.0, 0.0), Vec3(0.0, 1.0, 0.0)}},
     Polygon{{Vec3(0.0, 1.0, 1.0), Vec3(1.0, 1.0, 1.0), Vec3(1.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.19982489569838746},
    {"C11_parallel_opposed_rect_a2_b1_c1",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0), Vec3(2.0, 1.0, 0.0), Vec3(0.0, 1.0, 0.0)}},
     Polygon{{Vec3(0.0, 1.0, 1.0), Vec3(2.0, 1.0, 1.0), Vec3(2.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.2858753848507147},
    {"C11_parallel_opposed_rect_a1_b1_c0.5",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 1.0, 0.0), Vec3(0.0, 1.0, 0.0)}},
     Polygon{{Vec3(0.0, 1.0, 0.5), Vec3(1.0, 1.0, 0.5), Vec3(1.0, 0.0, 0.5), Vec3(0.0, 0.0, 0.5)}},
     0.4152532835771469},
    {"C11_parallel_opposed_rect_a2_b2_c1",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0), Vec3(2.0, 2.0, 0.0), Vec3(0.0, 2.0, 0.0)}},
     Polygon{{Vec3(0.0, 2.0, 1.0), Vec3(2.0, 2.0, 1.0), Vec3(2.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.4152532835771469},
    {"C11_parallel_opposed_rect_a3_b0.5_c2",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(3.0, 0.0, 0.0), Vec3(3.0, 0.5, 0.0), Vec3(0.0, 0.5, 0.0)}},
     Polygon{{Vec3(0.0, 0.5, 2.0), Vec3(3.0, 0.5, 2.0), Vec3(3.0, 0.0, 2.0), Vec3(0.0, 0.0, 2.0)}},
     0.07684039637490529},
    {"C11_parallel_opposed_rect_a10_b10_c1",
     Polygon{
         {Vec3(0.0, 0.0, 0.0), Vec3(10.0, 0.0, 0.0), Vec3(10.0, 10.0, 0.0), Vec3(0.0, 10.0, 0.0)}},
     Polygon{
         {Vec3(0.0, 10.0, 1.0), Vec3(10.0, 10.0, 1.0), Vec3(10.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.8269945223972565},
    {"C11_parallel_opposed_rect_a0.2_b0.2_c1",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(0.2, 0.0, 0.0), Vec3(0.2, 0.2, 0.0), Vec3(0.0, 0.2, 0.0)}},
     Polygon{{Vec3(0.0, 0.2, 1.0), Vec3(0.2, 0.2, 1.0), Vec3(0.2, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
     0.01240397731324307},
    {"C14_perpendicular_common_edge_l1_w1_h1",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 1.0, 0.0), Vec3(0.0, 1.0, 0.0)}},
     Polygon{{Vec3(0.0, 0.0, 1.0), Vec3(1.0, 0.0, 1.0), Vec3(1.0, 0.0, 0.0), Vec3(0.0, 0.0, 0.0)}},
     0.20004377607540316},
    {"C14_perpendicular_common_edge_l1_w2_h1",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 2.0, 0.0), Vec3(0.0, 2.0, 0.0)}},
     Polygon{{Vec3(0.0, 0.0, 1.0), Vec3(1.0, 0.0, 1.0), Vec3(1.0, 0.0, 0.0), Vec3(0.0, 0.0, 0.0)}},
     0.11642630139768095},
    {"C14_perpendicular_common_edge_l1_w1_h3",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 1.0, 0.0), Vec3(0.0, 1.0, 0.0)}},
     Polygon{{Vec3(0.0, 0.0, 3.0), Vec3(1.0, 0.0, 3.0), Vec3(1.0, 0.0, 0.0), Vec3(0.0, 0.0, 0.0)}},
     0.24175715069512566},
    {"C14_perpendicular_common_edge_l2_w0.5_h1.5",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(2.0, 0.0, 0.0), Vec3(2.0, 0.5, 0.0), Vec3(0.0, 0.5, 0.0)}},
     Polygon{{Vec3(0.0, 0.0, 1.5), Vec3(2.0, 0.0, 1.5), Vec3(2.0, 0.0, 0.0), Vec3(0.0, 0.0, 0.0)}},
     0.3573675384271083},
    {"C14_perpendicular_common_edge_l1_w0.2_h0.2",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 0.2, 0.0), Vec3(0.0, 0.2, 0.0)}},
     Polygon{{Vec3(0.0, 0.0, 0.2), Vec3(1.0, 0.0, 0.2), Vec3(1.0, 0.0, 0.0), Vec3(0.0, 0.0, 0.0)}},
     0.2710369356973576},
    {"C14_perpendicular_common_edge_l0.5_w2_h2",
     Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(0.5, 0.0, 0.0), Vec3(0.5, 2.0, 0.0), Vec3(0.0, 2.0, 0.0)}},
     Polygon{{Vec3(0.0, 0.0, 2.0), Vec3(0.5, 0.0, 2.0), Vec3(0.5, 0.0, 0.0), Vec3(0.0, 0.0, 0.0)}},
     0.10135870022168104},
};

// C-41: regular N-gons, vertex k at angle 2πk/N, emitter at z = 0 (CCW about +z), receiver at
// z = h listed clockwise seen from +z; vertex radius r (inscribed) or
// r sqrt(2π/(N sin(2π/N))) (area-matched). Values are F between the polygons.
const std::vector<NgonCase> kNgonCases = {
    {"C41_coaxial_disks_r1_1_r2_1_h1/N64_inscribed", 1.0, 1.0, 1.0, 64, false, 0.3816914385585072},
    {"C41_coaxial_disks_r1_1_r2_1_h1/N64_area_matched", 1.0, 1.0, 1.0, 64, true,
     0.38196591883125225},
    {"C41_coaxial_disks_r1_1_r2_1_h1/N256_inscribed", 1.0, 1.0, 1.0, 256, false,
     0.3819488604219251},
    {"C41_coaxial_disks_r1_1_r2_1_h1/N256_area_matched", 1.0, 1.0, 1.0, 256, true,
     0.38196601088945104},
    {"C41_coaxial_disks_r1_0.5_r2_1_h1/N64_inscribed", 0.5, 1.0, 1.0, 64, false,
     0.46849725729871144},
    {"C41_coaxial_disks_r1_0.5_r2_1_h1/N64_area_matched", 0.5, 1.0, 1.0, 64, true,
     0.4688710469872066},
    {"C41_coaxial_disks_r1_0.5_r2_1_h1/N256_inscribed", 0.5, 1.0, 1.0, 256, false,
     0.46884776983759513},
    {"C41_coaxial_disks_r1_0.5_r2_1_h1/N256_area_matched", 0.5, 1.0, 1.0, 256, true,
     0.4688711255429497},
    {"C41_coaxial_disks_r1_1_r2_0.5_h1/N64_inscribed", 1.0, 0.5, 1.0, 64, false,
     0.11712431432467788},
    {"C41_coaxial_disks_r1_1_r2_0.5_h1/N64_area_matched", 1.0, 0.5, 1.0, 64, true,
     0.1172177617468017},
    {"C41_coaxial_disks_r1_1_r2_0.5_h1/N256_inscribed", 1.0, 0.5, 1.0, 256, false,
     0.11721194245939895},
    {"C41_coaxial_disks_r1_1_r2_0.5_h1/N256_area_matched", 1.0, 0.5, 1.0, 256, true,
     0.11721778138573745},
    {"C41_coaxial_disks_r1_0.1_r2_0.2_h0.5/N64_inscribed", 0.1, 0.2, 0.5, 64, false,
     0.13375038250973956},
    {"C41_coaxial_disks_r1_0.1_r2_0.2_h0.5/N64_area_matched", 0.1, 0.2, 0.5, 64, true,
     0.13393124285279714},
    {"C41_coaxial_disks_r1_0.1_r2_0.2_h0.5/N256_inscribed", 0.1, 0.2, 0.5, 256, false,
     0.1339199464068867},
    {"C41_coaxial_disks_r1_0.1_r2_0.2_h0.5/N256_area_matched", 0.1, 0.2, 0.5, 256, true,
     0.13393125264314096},
    {"C41_coaxial_disks_r1_1_r2_2_h0.5/N64_inscribed", 1.0, 2.0, 0.5, 64, false,
     0.9247067901497069},
    {"C41_coaxial_disks_r1_1_r2_2_h0.5/N64_area_matched", 1.0, 2.0, 0.5, 64, true,
     0.9248161207257565},
    {"C41_coaxial_disks_r1_1_r2_2_h0.5/N256_inscribed", 1.0, 2.0, 0.5, 256, false,
     0.9248093592356754},
    {"C41_coaxial_disks_r1_1_r2_2_h0.5/N256_area_matched", 1.0, 2.0, 0.5, 256, true,
     0.9248161861516798},
    {"C41_coaxial_disks_r1_1_r2_1_h0.1/N64_inscribed", 1.0, 1.0, 0.1, 64, false, 0.904801169415911},
    {"C41_coaxial_disks_r1_1_r2_1_h0.1/N64_area_matched", 1.0, 1.0, 0.1, 64, true,
     0.9048738060007991},
    {"C41_coaxial_disks_r1_1_r2_1_h0.1/N256_inscribed", 1.0, 1.0, 0.1, 256, false,
     0.9048705360614385},
    {"C41_coaxial_disks_r1_1_r2_1_h0.1/N256_area_matched", 1.0, 1.0, 0.1, 256, true,
     0.9048750730060526},
};

Polygon ngon(double r, double z, int sides, bool area_matched, bool clockwise) {
    const double f =
        area_matched ? std::sqrt(2.0 * kPi / (sides * std::sin(2.0 * kPi / sides))) : 1.0;
    Polygon p;
    for (int k = 0; k < sides; ++k) {
        const int m = clockwise ? (sides - k) % sides : k;
        const double t = 2.0 * kPi * m / sides;
        p.vertices.emplace_back(r * f * std::cos(t), r * f * std::sin(t), z);
    }
    return p;
}

// Unit cube, faces x0, x1, y0, y1, z0, z1, normals inward.
const std::vector<Polygon> kCubeFaces = {
    Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(0.0, 1.0, 0.0), Vec3(0.0, 1.0, 1.0), Vec3(0.0, 0.0, 1.0)}},
    Polygon{{Vec3(1.0, 0.0, 1.0), Vec3(1.0, 1.0, 1.0), Vec3(1.0, 1.0, 0.0), Vec3(1.0, 0.0, 0.0)}},
    Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 1.0), Vec3(1.0, 0.0, 1.0), Vec3(1.0, 0.0, 0.0)}},
    Polygon{{Vec3(1.0, 1.0, 0.0), Vec3(1.0, 1.0, 1.0), Vec3(0.0, 1.0, 1.0), Vec3(0.0, 1.0, 0.0)}},
    Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 1.0, 0.0), Vec3(0.0, 1.0, 0.0)}},
    Polygon{{Vec3(0.0, 1.0, 1.0), Vec3(1.0, 1.0, 1.0), Vec3(1.0, 0.0, 1.0), Vec3(0.0, 0.0, 1.0)}}};
const double kCubeMatrix[6][6] = {{0.0, 0.19982489569838732, 0.20004377607540316,
                                   0.20004377607540316, 0.20004377607540316, 0.20004377607540316},
                                  {0.19982489569838732, 0.0, 0.20004377607540316,
                                   0.20004377607540316, 0.20004377607540316, 0.20004377607540316},
                                  {0.20004377607540316, 0.20004377607540316, 0.0,
                                   0.19982489569838732, 0.20004377607540316, 0.20004377607540316},
                                  {0.20004377607540316, 0.20004377607540316, 0.19982489569838732,
                                   0.0, 0.20004377607540316, 0.20004377607540316},
                                  {0.20004377607540316, 0.20004377607540316, 0.20004377607540316,
                                   0.20004377607540316, 0.0, 0.19982489569838732},
                                  {0.20004377607540316, 0.20004377607540316, 0.20004377607540316,
                                   0.20004377607540316, 0.19982489569838732, 0.0}};

// Closed 1 x 2 x 3 box, same face order.
const std::vector<Polygon> kBoxFaces = {
    Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(0.0, 2.0, 0.0), Vec3(0.0, 2.0, 3.0), Vec3(0.0, 0.0, 3.0)}},
    Polygon{{Vec3(1.0, 0.0, 3.0), Vec3(1.0, 2.0, 3.0), Vec3(1.0, 2.0, 0.0), Vec3(1.0, 0.0, 0.0)}},
    Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(0.0, 0.0, 3.0), Vec3(1.0, 0.0, 3.0), Vec3(1.0, 0.0, 0.0)}},
    Polygon{{Vec3(1.0, 2.0, 0.0), Vec3(1.0, 2.0, 3.0), Vec3(0.0, 2.0, 3.0), Vec3(0.0, 2.0, 0.0)}},
    Polygon{{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(1.0, 2.0, 0.0), Vec3(0.0, 2.0, 0.0)}},
    Polygon{{Vec3(0.0, 2.0, 3.0), Vec3(1.0, 2.0, 3.0), Vec3(1.0, 0.0, 3.0), Vec3(0.0, 0.0, 3.0)}}};
const double kBoxMatrix[6][6] = {{0.0, 0.4755764365329533, 0.15949835073952498, 0.15949835073952498,
                                  0.10271343099399842, 0.10271343099399842},
                                 {0.4755764365329533, 0.0, 0.15949835073952498, 0.15949835073952498,
                                  0.10271343099399842, 0.10271343099399842},
                                 {0.3189967014790498, 0.3189967014790498, 0.0, 0.1464145779311968,
                                  0.10779600955535155, 0.10779600955535155},
                                 {0.3189967014790498, 0.3189967014790498, 0.1464145779311968, 0.0,
                                  0.10779600955535155, 0.10779600955535155},
                                 {0.30814029298199513, 0.30814029298199513, 0.16169401433302732,
                                  0.16169401433302732, 0.0, 0.06033138536995475},
                                 {0.30814029298199513, 0.30814029298199513, 0.16169401433302732,
                                  0.16169401433302732, 0.06033138536995475, 0.0}};

}  // namespace

TEST_CASE("analytic: point_to_polygon matches Howell B-3 and B-4") {
    for (const PointCase& c : kPointCases) {
        CAPTURE(c.name);
        CHECK(std::abs(point_to_polygon(c.x, c.n, c.p) - c.exact) <= 1e-14);
    }
}

TEST_CASE("analytic: polygon_to_polygon matches Howell C-11 and C-14") {
    for (const PolygonCase& c : kPolygonCases) {
        CAPTURE(c.name);
        const double f = polygon_to_polygon(c.a, c.b);
        CAPTURE(f - c.exact);
        CHECK(std::abs(f - c.exact) <= 1e-12);
    }
}

void check_ngons(bool large) {
    for (const NgonCase& c : kNgonCases) {
        if ((c.sides > 64) != large) continue;
        CAPTURE(c.name);
        const Polygon a = ngon(c.r1, 0.0, c.sides, c.area_matched, false);
        const Polygon b = ngon(c.r2, c.h, c.sides, c.area_matched, true);
        const double f = polygon_to_polygon(a, b);
        CAPTURE(f - c.exact);
        CHECK(std::abs(f - c.exact) <= 1e-11);
    }
}

TEST_CASE("analytic: polygon_to_polygon matches the C-41 64-gon values") { check_ngons(false); }

TEST_CASE("analytic: polygon_to_polygon matches the C-41 256-gon values" *
          doctest::test_suite("slow")) {
    check_ngons(true);
}

TEST_CASE("analytic: enclosure matrices of the unit cube and the 1x2x3 box") {
    for (int which = 0; which < 2; ++which) {
        const auto& faces = which == 0 ? kCubeFaces : kBoxFaces;
        const auto& m = which == 0 ? kCubeMatrix : kBoxMatrix;
        for (int i = 0; i < 6; ++i) {
            double row = 0.0;
            for (int j = 0; j < 6; ++j) {
                CAPTURE(which);
                CAPTURE(i);
                CAPTURE(j);
                const double f = polygon_to_polygon(faces[static_cast<std::size_t>(i)],
                                                    faces[static_cast<std::size_t>(j)]);
                CHECK(std::abs(f - m[i][j]) <= 1e-12);
                row += f;
            }
            CHECK(std::abs(row - 1.0) <= 1e-12);
        }
    }
}
