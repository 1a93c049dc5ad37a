"""The simulated Ictineu AUV, its sensors and its EKF navigator (paper 002 §2, §4, §7)."""
