"""Stage logic that ties the packages together: train G/S, adapt R over the m-grid, evaluate.

Each function here is what one DVC stage does; the scripts in ``pipelines/``
only load params and call these.
"""
