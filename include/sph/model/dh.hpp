// Denavit-Hartenberg link transform and elementary rotations, templated on the scalar.
//
//   DH(theta, d, a, alpha) = Rz(theta) * Tz(d) * Tx(a) * Rx(alpha)
//
//       [ cos(theta)  -sin(theta)*cos(alpha)   sin(theta)*sin(alpha)   a*cos(theta) ]
//     = [ sin(theta)   cos(theta)*cos(alpha)  -cos(theta)*sin(alpha)   a*sin(theta) ]
//       [ 0            sin(alpha)              cos(alpha)              d            ]
//       [ 0            0                       0                       1            ]
//
// Angles in rad, lengths in mm. The scalar T may be double, float or ceres::Jet: the code calls
// unqualified sin/cos after `using std::sin;`, so argument-dependent lookup picks ceres::sin for
// Jets. This header includes Eigen only.
#ifndef SPH_MODEL_DH_HPP_
#define SPH_MODEL_DH_HPP_

#include <cmath>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

namespace sph {

template <typename T>
using Mat4 = Eigen::Matrix<T, 4, 4>;
template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Vec4 = Eigen::Matrix<T, 4, 1>;

/// Sine and cosine of one angle. Computing both together lets a dual number (ceres::Jet) evaluate
/// the transcendental part once.
template <typename T>
struct SinCos {
  T sin;
  T cos;
};

namespace internal {
/// SinCosOf() for a scalar: sin and cos.
template <typename T, typename = void>
struct SinCosImpl {
  static SinCos<T> Eval(const T& angle) {
    using std::cos;
    using std::sin;
    return {sin(angle), cos(angle)};
  }
};

/// SinCosOf() for a dual number: a type with a value part `a`, a derivative vector `v` and a
/// constructor T(a, v), as ceres::Jet has. sin(x) and cos(x) of a Jet each evaluate both the scalar
/// sine and cosine (the derivative of one is the other): two Jet calls, four transcendental
/// calls. This costs two, with identical results. Chosen by the type's shape, not by naming
/// ceres::Jet, so that this header needs no Ceres and no include order decides which one a
/// translation unit gets (a specialisation declared after a use would be silently ignored there).
template <typename T>
struct SinCosImpl<T, std::void_t<decltype(std::declval<const T&>().a), decltype(std::declval<const T&>().v),
                                 decltype(T(std::declval<const T&>().a, std::declval<const T&>().v))>> {
  static SinCos<T> Eval(const T& x) {
    using std::cos;
    using std::sin;
    const auto s = sin(x.a);
    const auto c = cos(x.a);
    return {T(s, c * x.v), T(c, -s * x.v)};
  }
};
}  // namespace internal

/// Returns {sin(angle), cos(angle)}.
template <typename T>
SinCos<T> SinCosOf(const T& angle) {
  return internal::SinCosImpl<T>::Eval(angle);
}

/// Rotation about z by `angle` [rad] as a homogeneous 4x4 transform.
template <typename T>
Mat4<T> RotZ(const T& angle) {
  const SinCos<T> t = SinCosOf(angle);
  Mat4<T> m;
  m << t.cos, -t.sin, T(0), T(0), t.sin, t.cos, T(0), T(0), T(0), T(0), T(1), T(0), T(0), T(0), T(0), T(1);
  return m;
}

/// Classic D-H link transform Rz(theta) * Tz(d) * Tx(a) * Rx(alpha); theta, alpha in rad, d, a in mm.
template <typename T>
Mat4<T> DhTransform(const T& theta, const T& d, const T& a, const T& alpha) {
  const SinCos<T> t = SinCosOf(theta);
  const SinCos<T> al = SinCosOf(alpha);
  Mat4<T> m;
  m << t.cos, -t.sin * al.cos, t.sin * al.sin, a * t.cos, t.sin, t.cos * al.cos, -t.cos * al.sin, a * t.sin, T(0),
      al.sin, al.cos, d, T(0), T(0), T(0), T(1);
  return m;
}

}  // namespace sph

#endif  // SPH_MODEL_DH_HPP_
