// Steady-state LQR gain: checked against the scalar DARE closed form, against a
// second implementation (the plain Riccati recursion run to convergence), and for
// closed-loop Schur stability; bad inputs give std::invalid_argument.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "netkf/theory/lqr.hpp"

namespace {

using netkf::Matrix;
using ::testing::HasSubstr;

double spectral_radius(const Matrix& M) {
  return Eigen::EigenSolver<Matrix>(M, false).eigenvalues().cwiseAbs().maxCoeff();
}

Matrix scalar(double v) { return Matrix::Constant(1, 1, v); }

// Scalar DARE x = a²x - a²b²x²/(r + b²x) + q  <=>  b²x² + (r - a²r - qb²)x - qr = 0;
// the stabilising solution is the non-negative root.
double scalar_dare(double a, double b, double q, double r) {
  const double c1 = r - a * a * r - q * b * b;
  return (-c1 + std::sqrt(c1 * c1 + 4.0 * b * b * q * r)) / (2.0 * b * b);
}

TEST(Lqr, ScalarMatchesClosedForm) {
  struct Case {
    double a, b, q, r;
  };
  for (const Case c : {Case{-1.25, 1.0, 1.0, 1.0}, Case{1.25, 1.0, 1.0, 2.5}, Case{2.5, -0.5, 3.0, 0.1},
                       Case{0.5, 2.0, 1.0, 1.0}, Case{1.0, 1.0, 1.0, 1.0}, Case{-3.0, 0.2, 0.01, 5.0}}) {
    SCOPED_TRACE(::testing::Message() << "a=" << c.a << " b=" << c.b << " q=" << c.q << " r=" << c.r);
    const double x = scalar_dare(c.a, c.b, c.q, c.r);
    const Matrix X = netkf::theory::solve_dare(scalar(c.a), scalar(c.b), scalar(c.q), scalar(c.r));
    EXPECT_NEAR(X(0, 0), x, 1e-12 * std::max(1.0, x));
    const double gain = c.b * x * c.a / (c.r + c.b * c.b * x);  // (r + b'xb)^{-1} b'xa
    const Matrix L = netkf::theory::lqr_gain(scalar(c.a), scalar(c.b), scalar(c.q), scalar(c.r));
    EXPECT_NEAR(L(0, 0), gain, 1e-12 * std::max(1.0, std::abs(gain)));
    EXPECT_LT(std::abs(c.a - c.b * L(0, 0)), 1.0);
  }
}

// Second implementation: iterate the Riccati recursion until it stops moving.
Matrix riccati_by_recursion(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru) {
  Matrix X = Qx;
  for (int k = 0; k < 100000; ++k) {
    const Matrix S = Ru + B.transpose() * X * B;
    const Matrix next =
        A.transpose() * X * A - A.transpose() * X * B * S.inverse() * B.transpose() * X * A + Qx;
    if ((next - X).norm() <= 1e-15 * next.norm()) return next;
    X = next;
  }
  return X;
}

TEST(Lqr, MatrixCasesAgreeWithTheRiccatiRecursion) {
  struct Case {
    Matrix A, B, Qx, Ru;
  };
  Matrix A1(3, 3);
  A1 << 1.25, 1, 0, 0, 0.9, 7, 0, 0, 0.6;  // Sinopoli's MIMO example
  Matrix A2(2, 2);
  A2 << 1.25, 0, 1, 1.1;  // Sinopoli / Liu-Goldsmith general example
  Matrix B2(2, 1);
  B2 << 1.0, 0.0;  // control only the first state: still stabilisable (x2 is driven by x1)
  Matrix A3(2, 2);
  A3 << 1.0, 0.1, 0.0, 1.0;  // discretised double integrator: eigenvalue 1 twice
  Matrix B3(2, 1);
  B3 << 0.005, 0.1;
  Matrix Q3(2, 2);
  Q3 << 1.0, 0.0, 0.0, 0.0;  // PSD only, but (A, Qx) detectable
  for (const Case& c : {Case{A1, Matrix::Identity(3, 3), Matrix::Identity(3, 3), Matrix::Identity(3, 3)},
                        Case{A2, B2, 20.0 * Matrix::Identity(2, 2), scalar(0.5)},
                        Case{A3, B3, Q3, scalar(0.01)}}) {
    const Matrix X = netkf::theory::solve_dare(c.A, c.B, c.Qx, c.Ru);
    const Matrix X_ref = riccati_by_recursion(c.A, c.B, c.Qx, c.Ru);
    EXPECT_LT((X - X_ref).norm(), 1e-9 * X_ref.norm()) << "X =\n" << X << "\nrecursion =\n" << X_ref;
    const Matrix L = netkf::theory::lqr_gain(c.A, c.B, c.Qx, c.Ru);
    ASSERT_EQ(L.rows(), c.B.cols());
    ASSERT_EQ(L.cols(), c.A.rows());
    const Matrix L_ref = (c.Ru + c.B.transpose() * X_ref * c.B).inverse() * c.B.transpose() * X_ref * c.A;
    EXPECT_LT((L - L_ref).norm(), 1e-8 * std::max(1.0, L_ref.norm()));
    EXPECT_LT(spectral_radius(c.A - c.B * L), 1.0);
  }
}

std::string invalid_argument_of(const Matrix& A, const Matrix& B, const Matrix& Qx, const Matrix& Ru) {
  try {
    netkf::theory::lqr_gain(A, B, Qx, Ru);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "<no std::invalid_argument>";
}

TEST(Lqr, RejectsWhatHasNoStabilisingSolution) {
  Matrix A(2, 2);
  A << 1.5, 0.0, 0.0, 0.5;
  Matrix B(2, 1);
  B << 0.0, 1.0;  // cannot reach the unstable mode 1.5
  EXPECT_THAT(invalid_argument_of(A, B, Matrix::Identity(2, 2), scalar(1.0)),
              HasSubstr("not stabilisable: the mode with eigenvalue 1.5"));
  Matrix Qx(2, 2);
  Qx << 0.0, 0.0, 0.0, 1.0;  // no weight on the unstable mode
  EXPECT_THAT(invalid_argument_of(A, Matrix::Identity(2, 2), Qx, Matrix::Identity(2, 2)), HasSubstr("not detectable"));
  EXPECT_THAT(invalid_argument_of(scalar(1.5), scalar(1.0), scalar(0.0), scalar(1.0)), HasSubstr("not detectable"));
}

TEST(Lqr, RejectsBadInputs) {
  const Matrix I2 = Matrix::Identity(2, 2);
  EXPECT_THAT(invalid_argument_of(Matrix::Identity(2, 3), I2, I2, I2), HasSubstr("A must be square"));
  EXPECT_THAT(invalid_argument_of(I2, Matrix::Identity(3, 1), I2, scalar(1.0)), HasSubstr("B must be"));
  EXPECT_THAT(invalid_argument_of(I2, I2, Matrix::Identity(3, 3), I2), HasSubstr("Qx must be 2x2"));
  EXPECT_THAT(invalid_argument_of(I2, I2, I2, scalar(1.0)), HasSubstr("Ru must be 2x2"));
  EXPECT_THAT(invalid_argument_of(I2, I2, I2, -I2), HasSubstr("Ru is not positive definite"));
  EXPECT_THAT(invalid_argument_of(I2, I2, -I2, I2), HasSubstr("Qx is not positive semidefinite"));
  Matrix bad = I2;
  bad(0, 1) = std::nan("");
  EXPECT_THAT(invalid_argument_of(bad, I2, I2, I2), HasSubstr("non-finite"));
}

}  // namespace
