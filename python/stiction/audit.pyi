from os import PathLike
from typing import Union

import pandas as pd

APPLICATION_ID: int
SCHEMA_VERSION: int

def load(path: Union[str, PathLike]) -> pd.DataFrame: ...
