"""Fitted models outside the report: a portable model file (JSON) that states a model's terms,
coefficients and uncertainty and what it was fitted for; a model loaded from it that predicts
one step ahead and runs free; the posterior draws as ArviZ InferenceData."""

from hmid.portable.file import FORMAT, read_model_file, write_model_file
from hmid.portable.model import Model, load_model

__all__ = ["FORMAT", "Model", "load_model", "read_model_file", "write_model_file"]
