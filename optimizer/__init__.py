"""The GALA optimizer: search (GA, learning automata, GALA), episode evaluation, results."""
