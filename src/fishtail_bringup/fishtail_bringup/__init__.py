"""Starting the fishtail node suite."""
