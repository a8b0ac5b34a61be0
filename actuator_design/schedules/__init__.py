"""Schedules: field, current and pose programmes between waypoints, greedy and optimal-control (issue 19)."""
