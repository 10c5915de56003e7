// Compile-fail test: a float scene given a DiracKernel<double>. The estimator's own constraints
// must reject it and name KernelOf (the kernel's scalar is not the scene's), before any member
// of the estimator is instantiated. Built with SEGPATH_COMPILE_FAIL_CONTROL defined, the
// kernel is DiracKernel<float> and the file must compile.
#include <segpath/estimators/sequential.hpp>
#include <segpath/kernels/dirac.hpp>
#include <segpath/testing/sphere_interior.hpp>

using Scene = segpath::testing::PhotographedSphereInterior<float>;
#ifdef SEGPATH_COMPILE_FAIL_CONTROL
using Kernel = segpath::DiracKernel<float>;
#else
using Kernel = segpath::DiracKernel<double>;
#endif

int main() {
  const segpath::SequentialEstimator<Scene, Kernel> estimator(Kernel{}, {1, 4});
  (void)estimator;
  return 0;
}
