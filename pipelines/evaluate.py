"""DVC stage evaluate: CRSE/CTE of WPM, G, S and R (every m) on the test drives; MLflow runs."""

from rwhonet import stage
from rwhonet.stages import evaluate

if __name__ == "__main__":
    stage.run("evaluate", evaluate.main)
