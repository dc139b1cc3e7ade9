#pragma once
/// \file host_device.h
/// `DYPHO_HOST_DEVICE` marks inline math compiled for both the CPU and (by nvcc) the GPU, so the
/// CPU rasterizer is the reference implementation of the CUDA one. No CUDA include here.

#ifdef __CUDACC__
#define DYPHO_HOST_DEVICE __host__ __device__
#else
#define DYPHO_HOST_DEVICE
#endif
