"""Reading inputs and writing artifacts: recordings, manifests, configs, staged atomic outputs."""
