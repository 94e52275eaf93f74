"""Optimisers over a RolloutService and a cost: CEM over pick actions, reduced iLQR, SVR."""
