from os import PathLike
from typing import Any, Dict, Iterable, List, Optional, Sequence, Union

import pandas as pd

BATCH_OPTIONS: tuple
SEARCH_OPTIONS: tuple

def options(*, stiction: Union[str, Sequence[str]] = ..., linear: Union[str, Sequence[str]] = ...,
            **kwargs: Any) -> str: ...
def rows_of_file(path: Union[str, PathLike], options_json: str,
                 label: Optional[str] = ...) -> List[Dict[str, Any]]: ...
def run(paths: Union[str, PathLike, Iterable[Union[str, PathLike]]], out: Optional[Union[str, PathLike]] = ...,
        *, valve: Optional[str] = ..., labels: Optional[Union[str, PathLike]] = ...,
        scheduler: Optional[str] = ..., client: Any = ..., n_workers: Optional[int] = ...,
        progress: bool = ..., db: Optional[Union[str, PathLike]] = ...,
        **batch_options: Any) -> pd.DataFrame: ...
def lines_of_file(path: Union[str, PathLike], options_json: str, label: Optional[str] = ...) -> List[str]: ...
