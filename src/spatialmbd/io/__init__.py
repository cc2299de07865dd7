"""Reading and writing model files (YAML or JSON, one versioned schema; docs/model-file.md)."""
from .modelfile import (SCHEMA_VERSION, Analysis, ModelFileError, load_builder, load_model,
                        model_to_dict, save_model, write_examples)

__all__ = ["SCHEMA_VERSION", "Analysis", "ModelFileError", "load_builder", "load_model",
           "model_to_dict", "save_model", "write_examples"]
