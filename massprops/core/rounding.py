"""The unit roundoff of IEEE double precision and γ(k), the relative error of k roundings
(Higham, *Accuracy and Stability of Numerical Algorithms*, §3.1): every error bound in
massprops is written with these two."""

U = 2.0 ** -53


def gamma(k):
    """γ(k) = k u / (1 − k u), for k u < 1."""
    return k * U / (1.0 - k * U)
