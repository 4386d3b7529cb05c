// What the study and benchmark programs simulate in common.
#ifndef SPH_BENCH_STUDY_DESIGNS_HPP_
#define SPH_BENCH_STUDY_DESIGNS_HPP_

#include <vector>

#include "sph/core/simulate.hpp"

namespace sph::bench {

/// form28: a form of the sphere of 0.050 um rms of degrees 2..8 on its body frame (the same terms
/// as bench/separation_study.sh's form28).
inline const std::vector<FormComponent>& Form28() {
  static const std::vector<FormComponent> form{
      {2, 0, 0.062},  {2, 2, -0.049}, {3, 1, 0.049},  {3, -3, 0.037}, {4, 0, -0.043}, {4, 2, 0.031}, {5, -2, 0.037},
      {5, 4, -0.025}, {6, 1, 0.031},  {6, -5, 0.025}, {7, 3, -0.025}, {8, 0, 0.025},  {8, -6, 0.019}};
  return form;
}

}  // namespace sph::bench

#endif  // SPH_BENCH_STUDY_DESIGNS_HPP_
