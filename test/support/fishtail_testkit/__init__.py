"""What the tests and benchmarks share and the product does not ship."""
