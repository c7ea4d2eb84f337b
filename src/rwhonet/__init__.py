"""rwhonet: learned wheel odometry (WhONet / R-WhONet) as a reproducible pipeline."""
