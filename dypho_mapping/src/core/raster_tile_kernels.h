#pragma once
/// \file raster_tile_kernels.h
/// Declarations of the two builds of the tile kernels (raster_tile_kernels.cpp, compiled once per
/// instruction set into its own namespace). Only the rasterizer picks between them (RasterIsa).

#include "dypho/mapping/rasterizer.h"

namespace dypho::mapping::raster {

#define DYPHO_DECLARE_TILE_KERNELS(ISA)                                                                        \
  namespace ISA {                                                                                              \
  template <typename T>                                                                                        \
  void forwardTile(const TileLists<T>& lists, int tile, const ForwardImages<T>& out);                          \
  template <typename T>                                                                                        \
  void backwardTile(const TileLists<T>& lists, int tile, const BackwardInputs<T>& in, gs::ScreenGrad<T>* acc); \
  }
DYPHO_DECLARE_TILE_KERNELS(generic)
DYPHO_DECLARE_TILE_KERNELS(avx2)
#undef DYPHO_DECLARE_TILE_KERNELS

}  // namespace dypho::mapping::raster
