// facecast-client: the client of the Facecast streaming protocol facecast.v1 (docs/protocol.md)
// for browsers and Node >= 20. See README.md.

export { FacecastClient, connect } from './client.js';
export { FacecastError, WeightsFrame, HEADER_BYTES, KIND, PROTOCOL, parseHeader, parseMedia, parseText } from './protocol.js';
export { StreamPlayer } from './player.js';
export { VRM_PRESETS, applyExpressions, applyWeights, morphMeshes, vrm0Name, vrm1Name } from './morphs.js';
