"""A Python re-implementation of the ltc_linear plugin (paper eq. 2, forward
Euler), for the tests and the docs: the same arithmetic in the same order as
plugins/ltc_common/ltc_predict.h."""

import numpy as np

import skidimm


class PythonLtc(skidimm.MotionModel):
    states = ("V", "omega")
    inputs = ("phi_dot_L", "phi_dot_R")
    fit_parameters = ("A", "B")

    def __init__(self, params):
        if set(params) != {"A", "B"}:
            raise ValueError(f"expected the parameters A and B, got {sorted(params)}")
        super().__init__({"A": np.array(params["A"], dtype=float), "B": np.array(params["B"], dtype=float)})

    def predict(self, x, u, dt):
        a, b = self.params["A"], self.params["B"]
        v_dot = a[0, 0] * x[0] + a[0, 1] * x[1] + b[0, 0] * u[0] + b[0, 1] * u[1]
        omega_dot = a[1, 0] * x[0] + a[1, 1] * x[1] + b[1, 0] * u[0] + b[1, 1] * u[1]
        return np.array([x[0] + v_dot * dt, x[1] + omega_dot * dt])

    def jacobian(self, x, u, dt):
        return np.eye(2) + self.params["A"] * dt


class PythonLtcNumericJacobian(PythonLtc):
    """The same without jacobian(): the engine differentiates predict()."""

    jacobian = skidimm.MotionModel.jacobian
