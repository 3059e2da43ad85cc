#pragma once
// The error map of a three-axis machine: the 21 geometric errors of ISO 230-1 as one model. Per axis J
// its six error motions as functions of its position (E_XJ, E_YJ, E_ZJ translations, E_AJ, E_BJ, E_CJ
// rotations about +x, +y, +z), plus the three squarenesses, evaluated through the machine's kinematic
// chain (bed -> Y -> X -> Z -> tool, as the virtual machine tool's; to first order) to the error vector of the tool point
// anywhere in the working volume. docs/map.md has the model, its conventions and the files.
//
// Each function is a sum of Legendre polynomials P_k(xi) over the axis' travel [lo, hi],
// xi = (2u - lo - hi) / (hi - lo), orders chosen by the data. What no test can see is fixed by
// convention (the gauge, docs/map.md "What a map is relative to"): positioning and the three angles of
// an axis have no P_0 (zero mean over the travel), a straightness has neither P_0 nor P_1 (it is relative
// to its least-squares line), so the slopes of the straightnesses, and the constant parts of the angles,
// are the squarenesses and a rigid-body motion of the volume.
//
// SI inside (m, rad). Pure functions; thread safe (a map is a value).

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace guideway::models::map {

using Vec3 = std::array<double, 3>;

// Component c of an axis' error motion: 0..2 translations along x, y, z; 3..5 rotations about x, y, z.
inline constexpr int components = 6;

// What a component is for its axis.
enum class Role { positioning, straightness, roll, pitch, yaw };

// ISO 230-1 name of component c of axis j: "EXX", "EYX", ..., "EAX", ..., "ECZ".
[[nodiscard]] std::string function_name(int axis, int component);
// "x", "y", "z".
[[nodiscard]] std::string axis_name(int axis);
[[nodiscard]] Role role_of(int axis, int component);
[[nodiscard]] std::string role_name(Role role);  // "positioning", "straightness", "roll", "pitch", "yaw"
// The component an autocollimator traverse of `axis` reads as pitch and as yaw (docs/conventions.md):
// X: rotation about y and about z; Y: about x and about z; Z: about y and about x.
[[nodiscard]] int pitch_component(int axis);
[[nodiscard]] int yaw_component(int axis);
// Lowest Legendre order a component may have (the gauge): 2 for a straightness, else 1.
[[nodiscard]] int lowest_order(int axis, int component);

// Legendre polynomials P_0..P_n at xi (n + 1 values) and their derivatives dP_k/dxi.
void legendre(double xi, int n, double* p, double* dp = nullptr);

struct Travel {
  double lo_m = 0.0;
  double hi_m = 0.0;
  [[nodiscard]] double xi(double u_m) const { return (2.0 * u_m - lo_m - hi_m) / (hi_m - lo_m); }
  [[nodiscard]] double length_m() const { return hi_m - lo_m; }
};

inline constexpr std::size_t no_parameter = std::numeric_limits<std::size_t>::max();

// One error function: sum_k coefficient[k] P_{orders[k]}(xi). Determined or not: a function no test of
// the day can see is not fitted (coefficients empty), and `why` says so with the test that would
// determine it.
struct ErrorFunction {
  int axis = 0;
  int component = 0;
  std::vector<int> orders;
  std::vector<double> coefficients;      // m or rad
  std::size_t first_parameter = no_parameter;  // of coefficients[0] in the map's parameter vector
  bool determined = false;
  std::string determined_by;  // the tests it comes from ("artifact Y", "traverse Y + artifact Y")
  std::string why;            // when not determined: why not, and what would determine it
};

// A squareness, as the virtual machine's [squareness] defines it (docs/machine.md): xy: the Y travel
// leans towards +x (actual x = x + q y); xz: Z leans towards +x; yz: Z leans towards +y.
struct SquarenessTerm {
  std::string plane;  // "xy", "xz", "yz"
  double value_rad = 0.0;
  std::size_t parameter = no_parameter;
  bool determined = false;
  std::string determined_by;
  std::string why;
};

// What the map holds and what it can tell.
struct ErrorMap {
  std::string machine;                 // name of the machine (from the tests' files)
  std::array<Travel, 3> travel{};      // per axis x, y, z: the range the tests covered
  std::array<int, 3> chain{1, 0, 2};   // from the bed up: Y, X, Z (tool on Z; workpiece on the bed)
  Vec3 tool_offset_m{};                // the tool the tests were measured with (Z carriage frame)
  std::array<std::array<ErrorFunction, components>, 3> functions{};
  std::array<SquarenessTerm, 3> squareness{};  // xy, xz, yz
  std::size_t parameters = 0;                  // length of the parameter vector
  std::vector<double> covariance;              // parameters x parameters, row-major (SI)

  [[nodiscard]] const ErrorFunction& function(int axis, int component) const {
    return functions[static_cast<std::size_t>(axis)][static_cast<std::size_t>(component)];
  }
  [[nodiscard]] ErrorFunction& function(int axis, int component) {
    return functions[static_cast<std::size_t>(axis)][static_cast<std::size_t>(component)];
  }
  // The function's value at position u (m); 0 when not determined.
  [[nodiscard]] double value(int axis, int component, double u_m) const;
  // Its standard uncertainty there (from the covariance); NaN when not determined.
  [[nodiscard]] double uncertainty(int axis, int component, double u_m) const;
  // The parameter vector (coefficients where they sit, squareness) and the covariance of one entry.
  [[nodiscard]] std::vector<double> parameter_vector() const;
  void set_parameters(const std::vector<double>& p);
  [[nodiscard]] double covariance_at(std::size_t i, std::size_t k) const {
    return covariance.empty() ? 0.0 : covariance[i * parameters + k];
  }
};

// A function's size over its travel (m or rad), for tables and reports.
struct FunctionFigures {
  double rms = 0.0;             // RMS over the travel
  double peak_to_valley = 0.0;  // max - min
  double u_rms = 0.0;           // RMS of its standard uncertainty over the travel (NaN: not determined)
};
[[nodiscard]] FunctionFigures function_figures(const ErrorMap& map, int axis, int component, int points = 101);

// Index of a squareness by plane name (0 xy, 1 xz, 2 yz), -1 for another name.
[[nodiscard]] int squareness_index(const std::string& plane);

// Every function not determined, its parameters unassigned, the squarenesses 0: a map to fill.
[[nodiscard]] ErrorMap empty_map(const std::array<Travel, 3>& travel, const Vec3& tool_offset_m);
// Gives each determined function (orders set) and each determined squareness its parameters, in order:
// functions by axis then component, then squareness xy, xz, yz. Coefficients are resized (0) and the
// covariance cleared.
void assign_parameters(ErrorMap& map);

// The machine's actual tool point less its nominal one (position + tool offset), at axis positions
// `position` (machine coordinates, m) with the tool at `tool_offset` in the Z carriage frame: the rigid-body
// chain of ISO 230-1 to first order (small angles), sum over the axes of E_J(u) + eps_J(u) x arm_J, the arm
// from a carriage to the tool being the nominal positions of the axes above it plus the tool offset, and the
// squarenesses' leans times the leaning axes' positions. Second-order terms (angle x angle x arm, angle x
// straightness) are left out: with the gauge's unknown constant angles they would be arbitrary (docs/map.md).
[[nodiscard]] Vec3 tool_error(const ErrorMap& map, const Vec3& position, const Vec3& tool_offset);
// The rotation (about x, y, z) of the carriage of `axis` and everything below it in the chain, to first
// order: what an angle sensor on that carriage reads.
[[nodiscard]] Vec3 carriage_angles(const ErrorMap& map, int axis, const Vec3& position);

// The arm of axis `axis`' rotations in `chain` (from the bed up): the nominal positions of the axes above it
// plus the tool offset. Its rotation eps adds eps x arm to the tool point's error.
[[nodiscard]] Vec3 rotation_arm(const std::array<int, 3>& chain, int axis, const Vec3& position, const Vec3& tool_offset);

// The derivatives of tool_error with respect to every parameter of the map (3 rows of `map.parameters`
// values, row-major; tool_error is linear in them).
void tool_error_jacobian(const ErrorMap& map, const Vec3& position, const Vec3& tool_offset, double* rows);
// The same for carriage_angles of `axis` (3 rows).
void carriage_angles_jacobian(const ErrorMap& map, int axis, const Vec3& position, double* rows);

}  // namespace guideway::models::map
