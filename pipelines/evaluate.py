"""DVC stage evaluate: CRSE/CTE of WPM, G, S and R (every m) on the test drives; MLflow runs."""

from rwhonet import runner
from rwhonet.stages import evaluate

if __name__ == "__main__":
    runner.run_script("evaluate", evaluate.main)
