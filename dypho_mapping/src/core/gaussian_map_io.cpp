/// Gaussian map files: 3DGS PLY and centre PCD.
#include "dypho/mapping/gaussian_map_io.h"

#include <algorithm>
#include <ostream>

#include "dypho/common/atomic_file.h"
#include "dypho/mapping/gaussian_ply.h"
#include "dypho/mapping/gaussian_sh.h"

namespace dypho::mapping {

std::vector<GaussianCentre> gaussianCentres(const GaussianMap& m) {
  std::vector<GaussianCentre> out(m.size());
  const float* p = m.data(kParamPosition);
  const float* sh = m.data(kParamSh);
  const int w = m.width(kParamSh);
  for (std::size_t i = 0; i < m.size(); ++i) {
    auto c8 = [&](int ch) {
      const float v = 0.5f + static_cast<float>(gs::kShC0) * sh[w * i + ch];
      return static_cast<std::uint8_t>(std::min(255.f, std::max(0.f, v * 255.f + 0.5f)));
    };
    out[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2], c8(0), c8(1), c8(2)};
  }
  return out;
}

void saveGaussianPly(const std::string& path, const GaussianMap& map) {
  writeFileAtomically(
      path, [&](std::ostream& os) { writeGaussianPly(os, map); }, true);
}

GaussianMap loadGaussianPly(const std::string& path, int sh_degree, std::size_t capacity, std::string* note) {
  GaussianMap loaded(sh_degree, capacity);
  readGaussianPly(path, loaded, note);
  return loaded;
}

void saveCentresPcd(const std::string& path, const std::vector<GaussianCentre>& pts) {
  writeFileAtomically(
      path,
      [&](std::ostream& os) {
        os << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\n"
           << "TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH " << pts.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS "
           << pts.size() << "\nDATA binary\n";
        for (const auto& p : pts) {
          const std::uint32_t rgb =
              (static_cast<std::uint32_t>(p.r) << 16) | (static_cast<std::uint32_t>(p.g) << 8) | p.b;
          os.write(reinterpret_cast<const char*>(&p.x), 12);
          os.write(reinterpret_cast<const char*>(&rgb), 4);
        }
      },
      true);
}

}  // namespace dypho::mapping
