// Pinocchio C++ yardstick for the `dynamics` crate: the KUKA LWR 4+ built exactly as in
// tools/gen_dynamics_fixtures.py (models A and B), the state of dynamics/benches/dynamics.rs, and
// per-call timings of crba, computeCoriolisMatrix, rnea and computeGeneralizedGravity measured the
// same way as dynamics/examples/bench_vs_pinocchio.rs (batches of calls; median and minimum over
// the batches of the mean time per call).
//
// crba is timed as Pinocchio returns it (upper triangle only, LOCAL convention, its default), with
// the lower triangle filled in afterwards (what dynamics::crba returns), and in the WORLD convention.
//
//   A: joint frames = classical DH frames, JointModelRevoluteUnaligned about Rx(alpha)^T e_z
//      (the frame layout of dynamics::lwr4(), the one the fixture test compares against).
//   B: JointModelRZ at the DH frames i-1, links moved into the joint frames (Pinocchio's fastest
//      joint type; same M(q) and C(q, qd)).
//
// Everything is instantiated from the headers in this translation unit (no
// PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION), so it is compiled with this file's flags.
//
// Usage: pinocchio_bench GOLDEN_JSON [--values]
//   GOLDEN_JSON  shared/data/lwr4-golden.json (link parameters, lwr4-model.md section 2.2)
//   --values     print M (both triangles) and C of both models with 17 digits and exit

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "pinocchio/multibody.hpp"
#include "pinocchio/algorithm/crba.hpp"
#include "pinocchio/algorithm/rnea.hpp"

namespace {

using pinocchio::Data;
using pinocchio::Inertia;
using pinocchio::Model;
using pinocchio::SE3;

constexpr int kJoints = 7;
constexpr double kHalfPi = M_PI / 2.0;
// lwr4-model.md section 1.1: T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), a_i = 0.
const double kAlpha[kJoints] = {kHalfPi, -kHalfPi, -kHalfPi, kHalfPi, kHalfPi, -kHalfPi, 0.0};
const double kD[kJoints] = {0.0, 0.0, 0.400, 0.0, 0.390, 0.0, 0.0};
constexpr double kG0 = 9.81;

struct Link {
  double mass;
  Eigen::Vector3d com;
  Eigen::Matrix3d inertia_com;
};

// Reads the `count` numbers after the first occurrence of `key` at or after `pos`.
std::vector<double> numbers_after(const std::string& text, const std::string& key, size_t& pos,
                                  int count) {
  pos = text.find(key, pos);
  if (pos == std::string::npos) throw std::runtime_error("key " + key + " not found");
  pos += key.size();
  std::vector<double> out;
  while (static_cast<int>(out.size()) < count) {
    while (pos < text.size() && std::string("-+.0123456789eE").find(text[pos]) == std::string::npos)
      ++pos;
    size_t used = 0;
    out.push_back(std::stod(text.substr(pos, 40), &used));
    pos += used;
  }
  return out;
}

// The seven links of lwr4-golden.json: {"m": .., "c": [3], "I_com": [xx, yy, zz, xy, xz, yz]}.
std::vector<Link> load_links(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw std::runtime_error("cannot open " + path);
  std::stringstream buffer;
  buffer << file.rdbuf();
  const std::string text = buffer.str();
  size_t pos = text.find("\"links\"");
  if (pos == std::string::npos) throw std::runtime_error("no \"links\" in " + path);
  std::vector<Link> links;
  for (int i = 0; i < kJoints; ++i) {
    Link link;
    link.mass = numbers_after(text, "\"m\":", pos, 1)[0];
    const auto c = numbers_after(text, "\"c\":", pos, 3);
    const auto j = numbers_after(text, "\"I_com\":", pos, 6);
    link.com = Eigen::Vector3d(c[0], c[1], c[2]);
    link.inertia_com << j[0], j[3], j[4], j[3], j[1], j[5], j[4], j[5], j[2];
    links.push_back(link);
  }
  return links;
}

Eigen::Matrix3d rot_x(double a) {
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

Model build_model_a(const std::vector<Link>& links) {
  Model model;
  model.gravity = pinocchio::Motion(Eigen::Vector3d(0, 0, -kG0), Eigen::Vector3d::Zero());
  pinocchio::JointIndex parent = 0;
  for (int i = 0; i < kJoints; ++i) {
    const SE3 placement(rot_x(kAlpha[i]), Eigen::Vector3d(0.0, 0.0, kD[i]));
    const Eigen::Vector3d axis = rot_x(kAlpha[i]).transpose() * Eigen::Vector3d::UnitZ();
    parent = model.addJoint(parent, pinocchio::JointModelRevoluteUnaligned(axis), placement,
                            "joint" + std::to_string(i + 1));
    model.appendBodyToJoint(parent, Inertia(links[i].mass, links[i].com, links[i].inertia_com),
                            SE3::Identity());
  }
  return model;
}

Model build_model_b(const std::vector<Link>& links) {
  Model model;
  model.gravity = pinocchio::Motion(Eigen::Vector3d(0, 0, -kG0), Eigen::Vector3d::Zero());
  pinocchio::JointIndex parent = 0;
  SE3 fixed_prev = SE3::Identity();
  for (int i = 0; i < kJoints; ++i) {
    parent = model.addJoint(parent, pinocchio::JointModelRZ(), fixed_prev,
                            "joint" + std::to_string(i + 1));
    const SE3 fixed(rot_x(kAlpha[i]), Eigen::Vector3d(0.0, 0.0, kD[i]));
    model.appendBodyToJoint(parent, Inertia(links[i].mass, links[i].com, links[i].inertia_com),
                            fixed);
    fixed_prev = fixed;
  }
  return model;
}

// Keeps the optimiser from dropping a computation whose result is otherwise unused.
template <typename T>
inline void keep(const T& value) {
  asm volatile("" : : "g"(&value) : "memory");
}

struct Timing {
  double median_ns;
  double min_ns;
};

// Median and minimum over `batches` of the mean time per call in a batch of `per_batch` calls.
template <typename F>
Timing measure(F&& f, int batches, int per_batch) {
  for (int i = 0; i < per_batch; ++i) f();  // warm-up
  std::vector<double> means;
  means.reserve(batches);
  for (int b = 0; b < batches; ++b) {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < per_batch; ++i) f();
    const auto stop = std::chrono::steady_clock::now();
    means.push_back(std::chrono::duration<double, std::nano>(stop - start).count() / per_batch);
  }
  std::sort(means.begin(), means.end());
  return {means[means.size() / 2], means.front()};
}

void print_matrix(const char* name, const Eigen::MatrixXd& m) {
  for (int i = 0; i < m.rows(); ++i) {
    std::printf("%s %d", name, i);
    for (int j = 0; j < m.cols(); ++j) std::printf(" %.17e", m(i, j));
    std::printf("\n");
  }
}

Eigen::MatrixXd symmetric_mass(const Model& model, Data& data, const Eigen::VectorXd& q) {
  pinocchio::crba(model, data, q);
  Eigen::MatrixXd m = data.M;
  m.triangularView<Eigen::StrictlyLower>() = m.transpose().triangularView<Eigen::StrictlyLower>();
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s GOLDEN_JSON [--values]\n", argv[0]);
    return 2;
  }
  const bool values = argc > 2 && std::string(argv[2]) == "--values";
  std::vector<Link> links;
  try {
    links = load_links(argv[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  const Model model_a = build_model_a(links);
  const Model model_b = build_model_b(links);
  Data data_a(model_a), data_b(model_b);

  Eigen::VectorXd q(kJoints), qd(kJoints), qdd(kJoints);
  q << 0.1, 0.5, -0.3, -1.2, 0.4, 0.9, -0.2;
  qd << 0.3, -0.2, 0.5, 0.1, -0.4, 0.6, 0.2;
  qdd << 1.0, -0.5, 0.2, 0.3, -0.1, 0.4, 0.7;

  if (values) {
    print_matrix("M_A", symmetric_mass(model_a, data_a, q));
    print_matrix("M_B", symmetric_mass(model_b, data_b, q));
    print_matrix("C_A", pinocchio::computeCoriolisMatrix(model_a, data_a, q, qd));
    print_matrix("C_B", pinocchio::computeCoriolisMatrix(model_b, data_b, q, qd));
    print_matrix("tau_A", pinocchio::rnea(model_a, data_a, q, qd, qdd).transpose());
    print_matrix("g_A", pinocchio::computeGeneralizedGravity(model_a, data_a, q).transpose());
    return 0;
  }

  constexpr int kBatches = 300;
  constexpr int kPerBatch = 2000;
  struct Row {
    std::string name;
    Timing t;
  };
  std::vector<Row> rows;
  for (int pass = 0; pass < 2; ++pass) {
    const Model& model = pass == 0 ? model_a : model_b;
    Data& data = pass == 0 ? data_a : data_b;
    const std::string tag = pass == 0 ? "/A" : "/B";
    rows.push_back({"crba" + tag, measure([&] { keep(pinocchio::crba(model, data, q)); },
                                          kBatches, kPerBatch)});
    // Pinocchio fills the upper triangle only; ours returns the full symmetric matrix.
    rows.push_back({"crba_symmetrised" + tag, measure(
                                                  [&] {
                                                    pinocchio::crba(model, data, q);
                                                    data.M.triangularView<Eigen::StrictlyLower>() =
                                                        data.M.transpose()
                                                            .triangularView<Eigen::StrictlyLower>();
                                                    keep(data.M);
                                                  },
                                                  kBatches, kPerBatch)});
    // The other convention of Pinocchio's crba (the default is LOCAL); also upper triangle only.
    rows.push_back({"crba_world" + tag,
                    measure([&] { keep(pinocchio::crba(model, data, q, pinocchio::Convention::WORLD)); },
                            kBatches, kPerBatch)});
    rows.push_back({"coriolis_matrix" + tag,
                    measure([&] { keep(pinocchio::computeCoriolisMatrix(model, data, q, qd)); },
                            kBatches, kPerBatch)});
    rows.push_back({"rnea" + tag,
                    measure([&] { keep(pinocchio::rnea(model, data, q, qd, qdd)); }, kBatches,
                            kPerBatch)});
    rows.push_back({"gravity" + tag,
                    measure([&] { keep(pinocchio::computeGeneralizedGravity(model, data, q)); },
                            kBatches, kPerBatch)});
  }
  std::printf("# pinocchio %s, eigen %d.%d.%d; ns per call: median and min over %d batches of %d\n",
              PINOCCHIO_VERSION, EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION,
              kBatches, kPerBatch);
  for (const auto& row : rows)
    std::printf("pinocchio %-24s %9.1f %9.1f\n", row.name.c_str(), row.t.median_ns, row.t.min_ns);
  return 0;
}
