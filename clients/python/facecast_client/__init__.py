"""Python client of the Facecast streaming protocol facecast.v1 (docs/protocol.md)."""
from .client import Client, Closed, FacecastTimeout, Utterance, connect
from .messages import (AudioChunk, Event, FacecastError, JpegFrame, ProtocolError, ServerError,
                       StreamEnd, StreamStart, WeightsFrame, parse_binary, parse_header)

__all__ = ["AudioChunk", "Client", "Closed", "Event", "FacecastError", "FacecastTimeout",
           "JpegFrame", "ProtocolError", "ServerError", "StreamEnd", "StreamStart", "Utterance",
           "WeightsFrame", "connect", "parse_binary", "parse_header"]
__version__ = "0.1.0"
