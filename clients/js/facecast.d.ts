// Types of facecast-client (facecast.js).

export * from './client.js';
export * from './protocol.js';
export * from './player.js';
export * from './morphs.js';
