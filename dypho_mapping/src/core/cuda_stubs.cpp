/// The CUDA classes in a build without CUDA: constructing one throws, saying why.
#include <stdexcept>

#include "dypho/mapping/cuda_rasterizer.h"
#include "dypho/mapping/cuda_trainer.h"

namespace dypho::mapping {

struct CudaRasterizer::Impl {};

CudaRasterizer::CudaRasterizer(const RasterSettings&) {
  throw std::runtime_error(
      "CudaRasterizer: dypho_mapping was built without CUDA (no nvcc found at configure time, or DYPHO_WITH_CUDA=OFF)");
}
CudaRasterizer::~CudaRasterizer() = default;
void CudaRasterizer::forward(const GaussianParamsView<float>&, const gs::PinholeView<float>&, RenderResult<float>&) {}
void CudaRasterizer::setParams(const GaussianParamsView<float>&) {}
void CudaRasterizer::forwardUploaded(const gs::PinholeView<float>&, RenderResult<float>&) {}
void CudaRasterizer::backward(const PixelGrads<float>&, GaussianGrads<float>&) {}
DeviceImages CudaRasterizer::forwardOnDevice(const GaussianParamsView<float>&, const gs::PinholeView<float>&) {
  return {};
}
DeviceGrads CudaRasterizer::backwardOnDevice(const PixelGrads<float>&, float*) { return {}; }
std::size_t CudaRasterizer::numTileEntries() const { return 0; }
std::size_t CudaRasterizer::numVisible() const { return 0; }
const RasterStageTimes& CudaRasterizer::stageTimes() const {
  static const RasterStageTimes none;
  return none;
}
const RasterSettings& CudaRasterizer::settings() const {
  static const RasterSettings none;
  return none;
}
void* CudaRasterizer::stream() const { return nullptr; }

struct CudaTrainer::Impl {};

CudaTrainer::CudaTrainer(const RasterSettings&) {
  throw std::runtime_error(
      "CudaTrainer: dypho_mapping was built without CUDA (no nvcc found at configure time, or DYPHO_WITH_CUDA=OFF)");
}
CudaTrainer::~CudaTrainer() = default;
void CudaTrainer::upload(const TrainingStateView&) {}
void CudaTrainer::download(const TrainingStateView&) {}
std::size_t CudaTrainer::size() const { return 0; }
void CudaTrainer::setTarget(std::int64_t, int, int, const float*, const float*, const std::uint8_t*) {}
bool CudaTrainer::hasTarget(std::int64_t) const { return false; }
void CudaTrainer::dropTarget(std::int64_t) {}
void CudaTrainer::clearTargets() {}
DeviceImages CudaTrainer::render(const gs::PinholeView<float>&) { return {}; }
void CudaTrainer::downloadRender(RenderResult<float>&) {}
CudaLossResult CudaTrainer::loss(std::int64_t, double, double, double, const float*) { return {}; }
void CudaTrainer::setPixelGrads(const float*, const float*, const float*) {}
void CudaTrainer::backwardAndStep(const AdamStepSizes&, float*, float) {}
DensifyOutcome CudaTrainer::densifyAndPrune(const DensifySettings&, std::size_t) { return {}; }
CudaRasterizer& CudaTrainer::rasterizer() { throw std::logic_error("CudaTrainer: built without CUDA"); }

}  // namespace dypho::mapping
