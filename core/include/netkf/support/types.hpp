#pragma once
// Basic linear-algebra aliases shared by the whole core library.
#include <Eigen/Dense>

namespace netkf {

using Matrix = Eigen::MatrixXd;
using Vector = Eigen::VectorXd;

}  // namespace netkf
