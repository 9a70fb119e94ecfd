"""End-to-end runs, the layer the CLI and the Python API call: ``fit`` (a measurement folder
in, a fit directory out), ``discover`` (a folder in, the named missing effect out)."""
