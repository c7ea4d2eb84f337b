"""MLflow tracking: the project's own store under mlruns/, one parent run per pipeline execution."""
