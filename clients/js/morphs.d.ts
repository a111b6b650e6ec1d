// Types of morphs.js: weights onto three.js meshes and three-vrm expressions (structural types: no
// dependency on three's typings).

/** A three.js Mesh with morph targets. */
export interface MorphMesh {
  isMesh?: boolean;
  morphTargetDictionary: Record<string, number>;
  morphTargetInfluences: number[];
}

/** A three.js Object3D (anything with traverse). */
export interface Traversable {
  traverse(callback: (object: any) => void): void;
}

/** three-vrm's VRMExpressionManager, as far as it is used. */
export interface ExpressionManager {
  getExpression(name: string): unknown;
  setValue(name: string, weight: number): void;
}

export type Weights = ArrayLike<number>;

/** (VRM 0.x name, VRM 1.0 name) of every preset both versions have. */
export declare const VRM_PRESETS: ReadonlyArray<readonly [string, string]>;
export declare function vrm1Name(name: string): string;
export declare function vrm0Name(name: string): string;
export declare function morphMeshes(root: Traversable | Traversable[]): MorphMesh[];
/** sets `values[i]` on every mesh's target named `names[i]`; returns the influences set */
export declare function applyWeights(target: Traversable | Traversable[] | MorphMesh[], names: string[], values: Weights): number;
/** sets three-vrm expressions by name (VRM 0.x presets under their 1.0 names); returns the expressions set */
export declare function applyExpressions(vrm: { expressionManager?: ExpressionManager | null } | ExpressionManager, names: string[], values: Weights): number;
