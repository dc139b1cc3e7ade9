# CUDA detection, shared by the package (CMakeLists.txt) and the standalone mapping build
# (dypho_mapping/standalone, what GPU machines without ROS build). nvcc is found on PATH, through
# CUDACXX or at /usr/local/cuda/bin/nvcc; the CPU path is complete without it.
# dypho_detect_cuda(): with DYPHO_WITH_CUDA on and nvcc found, enables CUDA (architectures
# 75 80 86 89 90 unless CMAKE_CUDA_ARCHITECTURES is set) and sets DYPHO_HAVE_CUDA ON.
# A macro: enable_language() must run in the caller's file scope.
macro(dypho_detect_cuda)
  set(DYPHO_HAVE_CUDA OFF)
  if(DYPHO_WITH_CUDA)
    include(CheckLanguage)
    if(NOT CMAKE_CUDA_COMPILER AND EXISTS /usr/local/cuda/bin/nvcc)
      set(CMAKE_CUDA_COMPILER /usr/local/cuda/bin/nvcc)
    endif()
    check_language(CUDA)
    if(CMAKE_CUDA_COMPILER)
      if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
        set(CMAKE_CUDA_ARCHITECTURES 75 80 86 89 90)
      endif()
      enable_language(CUDA)
      find_package(CUDAToolkit REQUIRED)
      set(DYPHO_HAVE_CUDA ON)
    endif()
  endif()
endmacro()
