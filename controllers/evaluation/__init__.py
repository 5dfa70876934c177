"""Laws judged in closed loop: seeded batch evaluation, the comparison of every law on every task, its report."""
